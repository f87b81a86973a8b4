"""tognet: task-oriented grasping for tool manipulation, learned from simulated self-supervision."""

__version__ = "0.1.0"
