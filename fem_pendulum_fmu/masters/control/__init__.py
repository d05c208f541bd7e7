"""Controller in the loop: any controller (an FMU, or a Python function) driving the pendulum FMU.

signals.py reads set-points and disturbances, series.py names the loop's table, controllers.py
adapts a controller FMU or a callable to one shape, loop.py is the fixed-step master, metrics.py
and checks.py turn a run into figures and assertions, command.py is `fem-pendulum control`.
"""
