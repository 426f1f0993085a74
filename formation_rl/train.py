"""`python -m formation_rl.train`: the entry point as documented before the apps moved, kept so users' scripts
run unchanged; the app is :mod:`formation_rl.apps.train` (same config, same outputs)."""

from formation_rl.apps.train import main

if __name__ == "__main__":
    main()
