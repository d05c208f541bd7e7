"""The FMI 2.0 layer: the interface declared by the template, the slave, the FMU entry script, the shim,
the builder and the host environment."""
