"""The rigid fidelity."""
