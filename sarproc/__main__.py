"""``python -m sarproc ...``: the same command line as the ``sarproc`` entry point."""

from sarproc.cli.main import main

if __name__ == "__main__":
    main()
