"""The command-line apps, one thin module per command: ``python -m formation_rl.apps.<name>``
(train, evaluate, render, demo, report, diagnose, ceiling, tune; ``make help`` lists them).
No app imports another; what two apps share lives in the library."""
