"""Experiments built on the environment and the controllers: ``experiments.study`` (the actuator design study)."""
