from chameleons.cli.main import main

main()
