"""`python -m formation_rl.visualize`: the entry point as documented before the apps moved, kept so users' scripts
run unchanged; the app is :mod:`formation_rl.apps.render` (same config, same outputs)."""

from formation_rl.apps.render import main

if __name__ == "__main__":
    main()
