"""tognet: task-oriented grasping for tool manipulation, learned from simulated self-supervision."""

from tognet.lazy_names import lazy_names

__version__ = "0.1.0"

# ``tognet.plan`` (:func:`tognet.planning.user.plan_image`), loaded on first use: ``import tognet`` and
# ``tognet --help`` stay free of torch.
__getattr__, __dir__ = lazy_names(__name__, {"plan": "tognet.planning.user:plan_image"})
