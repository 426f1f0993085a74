"""`python -m formation_rl.ceiling`: the entry point as documented before the apps moved, kept so users' scripts
run unchanged; the app is :mod:`formation_rl.apps.ceiling` (same config, same outputs)."""

from formation_rl.apps.ceiling import main

if __name__ == "__main__":
    main()
