"""A user's controller FMU, built by tests/test_control_loop.py with pythonfmu (its own binary, not the
project's): a PD law on the measured angle and velocity, torque = Kp (setpoint - theta) - Kd omega,
computed in doStep from the inputs set before it. Self-contained: pythonfmu loads it by module name."""

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability
from pythonfmu.enums import Fmi2Initial
from pythonfmu.variables import Real


class PdControllerUnderTest(Fmi2Slave):
    def __init__(self, **kwargs: object) -> None:
        super().__init__(**kwargs)
        self.theta = self.omega = self.setpoint = self.torque = 0.0
        self.Kp, self.Kd = 8.0, 0.4
        for name in ("theta", "omega", "setpoint"):
            self.register_variable(Real(name, causality=Fmi2Causality.input))
        self.register_variable(Real("torque", causality=Fmi2Causality.output))
        for name in ("Kp", "Kd"):
            self.register_variable(
                Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable,
                     initial=Fmi2Initial.exact)
            )  # fmt: skip

    def do_step(self, current_time: float, step_size: float) -> bool:
        self.torque = self.Kp * (self.setpoint - self.theta) - self.Kd * self.omega
        return True
