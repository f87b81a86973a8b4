"""tognet: task-oriented grasping for tool manipulation, learned from simulated self-supervision."""

__version__ = "0.1.0"


def __getattr__(name: str) -> object:
    """``tognet.plan`` (:func:`tognet.planning.user.plan_image`), loaded on first use: ``import tognet`` and
    ``tognet --help`` stay free of torch."""
    if name == "plan":
        from tognet.planning.user import plan_image

        globals()["plan"] = plan_image
        return plan_image
    raise AttributeError(f"module 'tognet' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), "plan"})
