"""The PID controller FMU of the controller-in-the-loop master: its entry script, template and builder."""
