"""The reduced fidelity."""
