from sarproc.cli.main import cli

cli(prog_name="sarproc")
