"""The ``meshservice`` command: ``serve`` the API, or print its ``openapi`` document."""

from __future__ import annotations

import argparse
import sys

from pydantic import ValidationError


def _serve(args: argparse.Namespace) -> int:
    import uvicorn

    from service.app import create_app
    from service.settings import Settings

    overrides = {
        k: v
        for k, v in {
            "host": args.host,
            "port": args.port,
            "data_dir": args.data_dir,
            "workers": args.workers,
        }.items()
        if v is not None
    }
    try:
        settings = Settings(**overrides)
    except ValidationError as exc:
        for error in exc.errors():
            print(f"meshservice: {error['msg']}", file=sys.stderr)
        return 2
    uvicorn.run(
        create_app(settings),
        host=settings.host,
        port=settings.port,
        log_level="info",
        timeout_graceful_shutdown=10,
    )
    return 0


def openapi_yaml() -> str:
    """The OpenAPI document of the app with the default methods, as YAML."""
    import yaml

    from service.app import create_app
    from service.settings import Settings

    spec = create_app(Settings()).openapi()
    return yaml.safe_dump(spec, sort_keys=False, allow_unicode=True, width=100)


def _openapi(_: argparse.Namespace) -> int:
    sys.stdout.write(openapi_yaml())
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="meshservice", description=__doc__)
    commands = parser.add_subparsers(dest="command")
    serve = commands.add_parser("serve", help="run the service (the default command)")
    serve.add_argument("--host", help="bind address (MESHSERVICE_HOST)")
    serve.add_argument("--port", type=int, help="port (MESHSERVICE_PORT)")
    serve.add_argument("--data-dir", help="job store directory (MESHSERVICE_DATA_DIR)")
    serve.add_argument("--workers", type=int, help="jobs run at once (MESHSERVICE_WORKERS)")
    serve.set_defaults(func=_serve)
    commands.add_parser("openapi", help="print the OpenAPI document as YAML").set_defaults(
        func=_openapi
    )
    args = parser.parse_args(argv)
    if args.command is None:
        args = parser.parse_args(["serve", *(argv or sys.argv[1:])])
    return args.func(args)
