"""`python -m formation_rl.rollout`: the entry point as documented before the apps moved, kept so users' scripts
run unchanged; it runs :mod:`formation_rl.apps.demo` as `python -m` would (its one-line checks, config, outputs)."""

import runpy

if __name__ == "__main__":
    runpy.run_module("formation_rl.apps.demo", run_name="__main__", alter_sys=True)
