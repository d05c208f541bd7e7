"""The fem fidelity."""
