"""Input interpolation and output derivatives through the FMU (fmpy's FMU2Slave), as a master uses them:
fmi2SetRealInputDerivatives of the torque makes the next doStep's torque a polynomial, cleared by the
step; fmi2GetRealOutputDerivatives answers the model's derivatives, fmi2Error for the per-step
summaries; an FMU state carries the derivatives set. The rigid fidelity (the physics of every
fidelity: tests/test_input_interpolation.py). Each test in a fresh interpreter (@isolated).
"""

from __future__ import annotations

from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu
from isolated import isolated
from test_fmu import Instance

RIGID = {"model.fidelity": 2}


class Pendulum(Instance):
    def vr(self, *names: str) -> list[int]:
        return [self.var[n].valueReference for n in names]

    def ramp(self, value: float, rate: float, curvature: float = 0.0) -> None:
        self.set("torque", value)
        self.fmu.setRealInputDerivatives(self.vr("torque", "torque"), [1, 2], [rate, curvature])

    def advance(self, h: float) -> list[float]:
        self.fmu.doStep(self.t, h)
        self.t += h
        return self.get("theta", "omega", "energy.total", "energy.torque_work")

    def derivatives(self, names: tuple[str, ...], order: int) -> list[float]:
        return self.fmu.getRealOutputDerivatives(self.vr(*names), [order] * len(names))


def test_both_fmus_declare_what_they_offer_and_pass_fmpy_validation(fmus):
    for fmu in fmus:
        assert validate_fmu(str(fmu)) == []
    cs = read_model_description(str(fmus[0])).coSimulation
    assert cs.canInterpolateInputs and cs.maxOutputDerivativeOrder == 2


@isolated
def test_a_ramped_doStep_ends_where_fine_doSteps_following_the_ramp_end(fmus, tmp_path):
    """20 ms in one doStep with the ramp's derivatives against 2000 doSteps of 10 us, each given the
    polynomial at its start: within 1 % of the ramp's effect (measured 0.50 % ramp, 0.61 % parabola,
    tests/test_input_interpolation.py), and 100 % off when the derivatives are left out."""
    for rate, curvature in ((50.0, 0.0), (50.0, 3000.0)):
        one, fine, held = (Pendulum(fmus[0], **RIGID) for _ in range(3))
        one.ramp(0.2, rate, curvature)
        theta_one = one.advance(0.02)[0]
        for k in range(2000):
            s = k * 1e-5
            fine.ramp(0.2 + rate * s + 0.5 * curvature * s * s, rate + curvature * s, curvature)
            theta_fine = fine.advance(1e-5)[0]
        held.set("torque", 0.2)
        effect = theta_fine - held.advance(0.02)[0]
        assert abs(effect) > 1e-3
        assert abs(theta_one - theta_fine) < 0.01 * abs(effect)
        for inst in (one, fine, held):
            inst.close()


@isolated
def test_derivatives_are_cleared_by_the_step_and_stay_when_the_value_is_set_after_them(fmus, tmp_path):
    a, b = Pendulum(fmus[0], **RIGID), Pendulum(fmus[0], **RIGID)
    a.ramp(0.2, 50.0)
    b.fmu.setRealInputDerivatives(b.vr("torque"), [1], [50.0])  # derivative first, then the value
    b.set("torque", 0.2)
    assert a.advance(0.01) == b.advance(0.01)
    after_ramp = a.advance(0.01)  # the value 0.2 held: the derivatives went with the step
    b.fmu.setRealInputDerivatives(b.vr("torque"), [1], [0.0])
    assert after_ramp == b.advance(0.01)
    a.close()
    b.close()


@isolated
def test_output_derivatives_are_the_models_and_summaries_have_none(fmus, tmp_path):
    inst = Pendulum(fmus[0], **RIGID)
    inst.ramp(0.3, 5.0)
    theta, omega, *_ = inst.advance(0.05)
    assert inst.derivatives(("theta",), 1) == [omega]
    accel = inst.derivatives(("theta", "omega"), 2)
    assert inst.derivatives(("omega",), 1) == [accel[0]]  # theta'' is omega'
    assert abs(accel[0]) > 1.0  # gravity's pull at 20 degrees: about 5 rad/s^2
    inst.set("torque", 2.3)  # the derivatives are those under the torque the next doStep takes
    assert inst.derivatives(("omega",), 1) != [accel[0]]
    mark = len(inst.messages)
    for summary in ("gap_min", "contact_force_max", "contact_impulse", "solver.substeps"):
        try:
            inst.fmu.getRealOutputDerivatives(inst.vr(summary), [1])
        except FMICallException as exc:
            assert "status 3" in str(exc)
        else:
            raise AssertionError(f"{summary} has a derivative")
    said = " ".join(inst.messages[mark:])
    for summary in ("gap_min", "contact_force_max", "contact_impulse", "solver.substeps"):
        assert f"{summary} (value reference {inst.vr(summary)[0]}) is a discrete output, not a continuous Real" in said
    inst.close()


@isolated
def test_bad_derivative_calls_are_refused_with_the_state_kept(fmus, tmp_path):
    inst = Pendulum(fmus[0], **RIGID)
    inst.ramp(0.2, 10.0)
    mark = len(inst.messages)
    for vr, order, value in ((inst.vr("theta0")[0], 1, 1.0), (0, 3, 1.0), (0, 0, 1.0), (0, 1, float("nan"))):
        try:
            inst.fmu.setRealInputDerivatives([vr], [order], [value])
        except FMICallException:
            continue
        raise AssertionError(f"order {order} of {vr} = {value} accepted")
    said = " ".join(inst.messages[mark:])
    assert "theta0 (value reference 13) is a fixed parameter, not a continuous Real input" in said
    assert "order 3 of torque (value reference 0) is not allowed: the orders are 1 to 2" in said
    assert "it must be a finite number" in said
    reference = Pendulum(fmus[0], **RIGID)  # made after: fmpy's logger proxy sends messages to the last instance's
    reference.ramp(0.2, 10.0)
    assert inst.advance(0.01) == reference.advance(0.01)  # the ramp set before is what the step took
    inst.close()
    reference.close()


@isolated
def test_a_state_with_derivatives_set_continues_bit_identically(fmus, tmp_path):
    inst = Pendulum(fmus[0], **RIGID)
    inst.advance(0.01)
    inst.ramp(-0.4, 30.0, -900.0)
    state, t = inst.fmu.getFMUstate(), inst.t
    blob = bytes(inst.fmu.serializeFMUstate(state))
    first = [inst.advance(0.01), inst.advance(0.01)]
    inst.fmu.setFMUstate(state)
    inst.t = t
    assert [inst.advance(0.01), inst.advance(0.01)] == first
    other = Pendulum(fmus[0], **RIGID)
    other.fmu.setFMUstate(other.fmu.deSerializeFMUstate(blob))
    other.t = t
    assert [other.advance(0.01), other.advance(0.01)] == first
    inst.fmu.freeFMUstate(state)
    inst.close()
    other.close()


def test_the_model_structure_lists_no_feedthrough_and_the_initial_unknowns_with_their_knowns(fmus):
    """Outputs: no output depends on an input at the same communication point (both FMUs compute their
    outputs in doStep); InitialUnknowns: the outputs with initial="calculated", each depending only on
    knowns of initializationMode (variables with initial="exact"), the pendulum's angle on theta0."""
    for fmu in fmus:
        md = read_model_description(str(fmu))
        outputs = {v for v in md.modelVariables if v.causality == "output"}
        assert {u.variable for u in md.outputs} == outputs and all(u.dependencies == [] for u in md.outputs)
        assert {u.variable for u in md.initialUnknowns} == {v for v in outputs if v.initial == "calculated"}
        for unknown in md.initialUnknowns:
            assert all(d.initial == "exact" and d.causality != "input" for d in unknown.dependencies)
    md = read_model_description(str(fmus[0]))
    theta = next(u for u in md.initialUnknowns if u.variable.name == "theta")
    assert "theta0" in {d.name for d in theta.dependencies} and "torque" not in {d.name for d in theta.dependencies}


@isolated
def test_outputs_in_initialization_mode_are_those_of_the_parameters_set(fmus, tmp_path):
    """The InitialUnknowns read in initializationMode: the initial state of the parameters set so far
    (theta = theta0), following a parameter set after the read; a solver setting changes none of them
    (bit for bit: it is not among their dependencies); exitInitializationMode starts from that state."""
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmus[0]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmus[0])), modelIdentifier="FemPendulum")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setInteger([vr["model.fidelity"]], [2])
    outputs = [vr[n] for n in ("theta", "omega", "gap", "energy.total", "energy.potential")]
    slave.setReal([vr["theta0"]], [0.3])
    at_03 = slave.getReal(outputs)
    slave.setReal([vr["theta0"], vr["solver.max_step"]], [0.2, 5e-4])
    at_02 = slave.getReal(outputs)
    assert at_03[0] == 0.3 and at_02[0] == 0.2 and at_02[2] < at_03[2]  # closer to the wall
    slave.setReal([vr["solver.max_step"]], [2e-3])
    assert slave.getReal(outputs) == at_02
    slave.exitInitializationMode()
    assert slave.getReal(outputs) == at_02
    slave.terminate()
    slave.freeInstance()
