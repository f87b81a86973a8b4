"""The planning service (``tognet serve``, optional extra ``serve``: FastAPI and uvicorn) and its client.

    from tognet.serve import Client
    plan = Client("http://127.0.0.1:8080").plan(depth, intrinsics, task="hammering")

:mod:`tognet.serve.app` builds the app (``create_app``); :mod:`tognet.serve.client` needs only the
standard library.
"""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names

if TYPE_CHECKING:
    from tognet.serve.app import ServeConfig, create_app
    from tognet.serve.client import Client, ServiceError

__getattr__, __dir__ = lazy_names(__name__, {
    "Client": "tognet.serve.client",
    "ServiceError": "tognet.serve.client",
    "ServeConfig": "tognet.serve.app",
    "create_app": "tognet.serve.app",
})
__all__ = ["Client", "ServeConfig", "ServiceError", "create_app"]
