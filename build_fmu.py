"""Build dist/FemPendulum.fmu and dist/PidController.fmu: the same as `fem-pendulum build`.

python build_fmu.py [--output dist/FemPendulum.fmu] [--no-controller]
"""

from fem_pendulum_fmu.cli import main

if __name__ == "__main__":
    import sys

    main(["build", *sys.argv[1:]])
