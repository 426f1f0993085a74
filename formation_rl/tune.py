"""`python -m formation_rl.tune`: the entry point as documented before the apps moved, kept so users' scripts
run unchanged; the app is :mod:`formation_rl.apps.tune` (same config, same outputs)."""

from formation_rl.apps.tune import main

if __name__ == "__main__":
    main()
