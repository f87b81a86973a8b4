"""``tognet serve``: the planning service over HTTP (FastAPI on uvicorn; the optional extra ``serve``)."""

from __future__ import annotations

import typer

from tognet.cli.util import user_errors

EXTRA_HINT = "pip install 'tognet[serve]'"


@user_errors
def serve_cmd(
    host: str = typer.Option("127.0.0.1", "--host", help="Address to bind. 127.0.0.1: this machine only; "
                             "0.0.0.0 opens the service to the network (no authentication: a trusted one)."),
    port: int = typer.Option(8080, "--port", min=0, max=65535, help="TCP port (0: any free one, printed)."),
    threads: int = typer.Option(0, "--threads", min=0, help="Plans at once, one torch thread each (0: the "
                                "machine's cores)."),
    preload: str = typer.Option("", "--preload", help="Tasks (comma-separated, or all) whose default "
                                "planner is loaded at start; the others load on their first request."),
    max_request_mb: float = typer.Option(32.0, "--max-request-mb", min=0.001,
                                         help="Largest request accepted (MB); larger: 413."),
    max_pixels: int = typer.Option(4096 * 4096, "--max-pixels", min=1,
                                   help="Largest depth image accepted (width x height); larger: 413."),
    timeout: float = typer.Option(30.0, "--timeout", min=0.001, help="Seconds a plan may take; then 504."),
) -> None:
    """Serve plans over HTTP: POST /plan (a depth image and its intrinsics; the JSON of tognet plan --out),
    GET /health, GET /methods, the API's page at /docs. The models load once and stay loaded.

    Example: curl -F depth=@d.png -F intrinsics=@d.intrinsics.json -F task=hammering
    http://127.0.0.1:8080/plan
    """
    import importlib.util

    for module in ("fastapi", "uvicorn", "multipart"):
        if importlib.util.find_spec(module) is None:
            raise ValueError(f"tognet serve needs the serve extra ({module} is missing): {EXTRA_HINT}")
    import uvicorn

    from tognet.cli.util import task_list
    from tognet.serve.app import ServeConfig, create_app

    config = ServeConfig(host=host, port=port, threads=threads, max_request_mb=max_request_mb,
                         max_pixels=max_pixels, timeout_s=timeout,
                         preload=tuple(task_list(preload)) if preload else ())
    app = create_app(config)

    class Server(uvicorn.Server):
        async def startup(self, sockets: list | None = None) -> None:  # type: ignore[type-arg]
            await super().startup(sockets)
            bound = [s.getsockname() for srv in self.servers for s in srv.sockets]
            where = ", ".join(f"http://{h}:{p}" for h, p, *_ in bound) or f"http://{host}:{port}"
            typer.echo(f"tognet serve: listening on {where} (docs at /docs); Ctrl-C stops it", err=True)

    Server(uvicorn.Config(app, host=host, port=port, log_level="warning", timeout_keep_alive=5)).run()


def register(app: typer.Typer) -> None:
    """Add ``serve`` to the tognet command."""
    app.command("serve")(serve_cmd)
