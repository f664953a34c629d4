from sarproc.cli.main import main

main()
