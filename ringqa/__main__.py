"""``python -m ringqa`` runs the command line."""

from ringqa.cli import console_main

console_main()
