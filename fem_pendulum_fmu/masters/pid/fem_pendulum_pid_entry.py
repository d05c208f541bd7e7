"""Entry script of the PidController FMU: self-contained (unique module name, no package import),
so that it never shadows the pendulum FMU's bundled package in a shared interpreter."""

from dataclasses import dataclass

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability
from pythonfmu.enums import Fmi2Initial
from pythonfmu.variables import Real


@dataclass
class Pid:
    kp: float = 10.0
    ki: float = 4.0
    kd: float = 0.15
    u_max: float = 15.0
    integral: float = 0.0
    last_error: float | None = None

    def update(self, setpoint: float, measurement: float, dt: float) -> float:
        """Output for a step of length dt; the integral stops growing while the output saturates."""
        error = setpoint - measurement
        derivative = 0.0 if self.last_error is None else (error - self.last_error) / dt
        self.last_error = error
        candidate = self.integral + error * dt
        u = self.kp * error + self.ki * candidate + self.kd * derivative
        if abs(u) <= self.u_max:
            self.integral = candidate
        else:
            u = self.kp * error + self.ki * self.integral + self.kd * derivative
        return max(-self.u_max, min(self.u_max, u))


class PidController(Fmi2Slave):
    """PID controller: setpoint and measurement in, saturated torque demand u out."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__(**kwargs)
        self.setpoint = 0.0
        self.measurement = 0.0
        self.u = 0.0
        self.Kp, self.Ki, self.Kd, self.u_max = 10.0, 4.0, 0.15, 15.0
        self.pid: Pid | None = None
        for name in ("setpoint", "measurement"):
            self.register_variable(Real(name, causality=Fmi2Causality.input))
        self.register_variable(Real("u", causality=Fmi2Causality.output))
        for name in ("Kp", "Ki", "Kd", "u_max"):
            self.register_variable(
                Real(
                    name,
                    causality=Fmi2Causality.parameter,
                    variability=Fmi2Variability.fixed,
                    initial=Fmi2Initial.exact,
                )
            )

    def exit_initialization_mode(self) -> None:
        self.pid = Pid(self.Kp, self.Ki, self.Kd, self.u_max)

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self.pid is None or not step_size > 0:
            return False
        self.u = self.pid.update(self.setpoint, self.measurement, step_size)
        return True
