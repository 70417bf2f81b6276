from d2sr.cli import main

main()
