"""`python -m formation_rl.rollout`: the entry point as documented before the apps moved, kept so users' scripts
run unchanged; the app is :mod:`formation_rl.apps.demo` (same config, same outputs)."""

from formation_rl.apps.demo import main

if __name__ == "__main__":
    main()
