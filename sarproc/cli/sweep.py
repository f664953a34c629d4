"""sarproc sweep SWEEP.yaml [-o DIR] [--scheduler serial|local|ADDRESS] [--workers N]"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from sarproc.cli.options import SectionCommand, summary, verbosity

if TYPE_CHECKING:
    from sarproc.cli.sweep_tasks import Outcome, Plan


@click.command(cls=SectionCommand, section="sweep")
@click.argument("sweep_path", type=click.Path(dir_okay=False, allow_dash=True, path_type=Path))
@click.option(
    "-o",
    "--output",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Output directory (default: the sweep file's 'output:').",
)
@click.option(
    "--scheduler",
    default=None,
    help="'local' (a new Dask LocalCluster), 'serial' (this process, no Dask) or the address of a "
    "running Dask scheduler, e.g. tcp://host:8786. Default: local, or serial (with a note) when "
    "Dask is not installed.",
)
@click.option(
    "--table",
    "table_path",
    type=click.Path(dir_okay=False, allow_dash=True, path_type=Path),
    default=None,
    help="Also write the Markdown table to this file ('-': standard output).",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Workers of the local cluster (default: the number of cores).",
)
@click.option(
    "--threads-per-worker",
    type=click.IntRange(min=1),
    default=1,
    show_default=True,
    help="Threads of each local worker (the stages use all cores of their worker already).",
)
@click.option(
    "--processes/--threads",
    default=True,
    show_default=True,
    help="Local workers as processes or as threads of this process.",
)
@click.option("--list", "list_only", is_flag=True, help="Print the tasks and exit.")
def sweep(
    sweep_path: Path,
    output: Path | None,
    scheduler: str | None,
    table_path: Path | None,
    workers: int,
    threads_per_worker: int,
    processes: bool,
    list_only: bool,
) -> None:
    """Run a grid of scenes x stage knobs (simulate -> focus -> evaluate) and gather one table.

    Every step writes its own product under DIR (raw/, tasks/<id>/); a step whose output already
    exists with the same resolved inputs is skipped, so a killed sweep resumes when rerun. Writes
    DIR/table.md, DIR/table.json and DIR/plot.png. Dask is needed for 'local' or an address
    (pip install 'sarproc[distributed]'); see docs/sweeps.md for a SLURM cluster. SWEEP_PATH '-'
    reads the sweep from standard input (relative paths then start in the current directory).
    """
    from sarproc.cli.sweep_tasks import plan_sweep, sweep_table, write_results
    from sarproc.product import run
    from sarproc.product.errors import ProcessingError
    from sarproc.product.io import atomic_path, check_output_path

    plan = plan_sweep(sweep_path, output)
    if list_only:
        for task in plan.tasks:
            click.echo(f"{task.task_id}\t{task.directory}")
        summary(f"sweep: {len(plan.tasks)} tasks, {len(plan.sims)} raw products")
        return
    # Two sweeps into one directory would share steps: the second stops here, naming the first.
    try:
        plan.output.mkdir(parents=True, exist_ok=True)
    except PermissionError as exc:  # session 43 row 11: it said only "<dir>: Permission denied"
        from sarproc.product.errors import InputError

        raise InputError(
            f"{plan.output}: cannot create the output directory: {exc.strerror}; choose a writable location"
        ) from None
    check_output_path(plan.output / "table.md", overwrite=True)
    if table_path is not None:
        check_output_path(table_path, [sweep_path], overwrite=True)
    table_on_stdout = run.stdout_taken()
    run.take_stdout(False)  # not yet: the steps' own summaries are captured from stdout for their records
    run.keep_published_on_interrupt()  # finished steps stay: a rerun resumes from them
    outcome, runner = _run(plan, scheduler or _default_scheduler(), workers, threads_per_worker, processes)
    paths = write_results(plan, outcome, runner)
    run.take_stdout(table_on_stdout)
    if table_path is not None:
        with atomic_path(table_path) as tmp:
            tmp.write_text(sweep_table(plan, outcome.rows) + "\n", encoding="utf-8")
    _report(plan, outcome, runner, paths["md"])
    if outcome.failures:
        raise ProcessingError(f"sweep: {len(outcome.failures)} task(s) failed; rerun to retry them")


def _default_scheduler() -> str:
    """'local' where Dask is installed, else 'serial' (said once on stderr)."""
    try:
        import dask.distributed  # noqa: F401

        return "local"
    except ImportError:
        if verbosity() >= 0:
            click.echo(
                "sweep: Dask is not installed: the tasks run one after the other in this process "
                "(pip install 'sarproc[distributed]' to run them in parallel)",
                err=True,
            )
        return "serial"


def _run(plan: Plan, scheduler: str, workers: int, threads_per_worker: int, processes: bool) -> tuple[Outcome, str]:
    """Run the plan's tasks serially or on Dask: (the outcome, where it ran in words)."""
    import logging
    import os

    from sarproc.cli.sweep_tasks import local_client, run_dask, run_serial
    from sarproc.product.errors import InputError

    if scheduler == "serial":
        return run_serial(plan), "serial"
    try:
        from dask.distributed import Client
    except ImportError:
        raise InputError(
            "--scheduler: Dask is not installed; pip install 'sarproc[distributed]' or use --scheduler serial"
        ) from None
    # distributed logs its cluster's life at INFO; show it only when sarproc itself is verbose
    logging.getLogger("distributed").setLevel(max(logging.getLogger().level, logging.WARNING))
    if scheduler == "local":
        client = local_client(workers or os.cpu_count() or 1, threads_per_worker, processes)
        runner = f"local Dask cluster, {len(client.scheduler_info()['workers'])} workers"
    else:
        try:
            client = Client(scheduler)  # waits distributed.comm.timeouts.connect (dask config)
        except (OSError, ValueError) as exc:
            raise InputError(f"--scheduler: cannot reach Dask scheduler {scheduler}: {exc}") from None
        runner = f"Dask scheduler {scheduler}, {len(client.scheduler_info()['workers'])} workers"
    try:
        return run_dask(plan, client), runner
    finally:
        cluster = client.cluster if scheduler == "local" else None
        client.close()
        if cluster is not None:
            cluster.close()


def _report(plan: Plan, outcome: Outcome, runner: str, table_md: Path) -> None:
    """The failed tasks' errors on stderr and the summary line."""
    skipped = sum(1 for r in outcome.rows if r["skipped"])
    refused = sum(1 for r in outcome.rows if r.get("refused") is not None)
    for task, error in outcome.failures:
        click.echo(f"sweep: task {task} failed: {error}", err=True)
    summary(
        f"sweep: {len(outcome.rows)}/{len(plan.tasks)} tasks ({skipped} already done"
        + (f", {refused} refused their input" if refused else "")
        + f") on {runner} "
        f"in {outcome.seconds:.1f} s -> {table_md}"
    )
