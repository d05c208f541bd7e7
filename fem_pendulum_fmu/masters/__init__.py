"""fmpy masters that drive the FMU: open loop (a torque profile) and a controller in the loop."""
