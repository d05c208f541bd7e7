"""The physics: scene, geometry, material, contact laws, modes, time stepping and the models. Knows nothing of FMI."""
