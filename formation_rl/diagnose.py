"""`python -m formation_rl.diagnose`: the entry point as documented before the apps moved, kept so users' scripts
run unchanged; the app is :mod:`formation_rl.apps.diagnose` (same config, same outputs)."""

from formation_rl.apps.diagnose import main

if __name__ == "__main__":
    main()
