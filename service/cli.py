"""The ``meshservice`` command.

``serve`` runs the API; ``openapi`` prints its OpenAPI document; ``submit``,
``jobs`` and ``cancel`` are a batch client of a running service (URL and key
from ``--url``/``--key`` or ``MESHSERVICE_URL``/``MESHSERVICE_API_KEY``).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from pydantic import ValidationError

from meshcore.mesh.formats import FORMATS
from service.client import ServiceError


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
        timeout_keep_alive=settings.keep_alive,
    )
    return 0


def openapi_yaml() -> str:
    """The OpenAPI document of the app with the default methods and API keys set, as YAML.

    With keys (as every deployment beyond loopback has them) the document
    carries the bearer security scheme and the 401 answers; a service
    without keys serves its own document without them at ``/openapi.json``.
    """
    import yaml

    from service.app import create_app
    from service.settings import Settings

    spec = create_app(Settings(api_keys="KEY:client")).openapi()
    return yaml.safe_dump(spec, sort_keys=False, allow_unicode=True, width=100)


def _openapi(_: argparse.Namespace) -> int:
    sys.stdout.write(openapi_yaml())
    return 0


def _client(args: argparse.Namespace):
    from service.client import MeshClient

    return MeshClient(args.url, args.key)


def _submit(args: argparse.Namespace) -> int:
    from service.batch import read_items, run_batch

    try:
        items = read_items(args.files)
    except ValueError as exc:
        print(f"meshservice: {exc}", file=sys.stderr)
        return 2
    if not items:
        print("meshservice: no jobs in the given files", file=sys.stderr)
        return 2
    with _client(args) as api:
        out = Path(args.out) if args.out else None
        return run_batch(api, items, wait=args.wait, out=out, fmt=args.format)


def _jobs(args: argparse.Namespace) -> int:
    with _client(args) as api:
        print(f"{'id':<32} {'method':<20} {'status':<10} {'progress':>8} created")
        for n, job in enumerate(api.jobs()):
            if n == args.limit:
                break
            fraction = job["progress"]["fraction"]
            print(
                f"{job['id']:<32} {job['method']:<20} {job['status']:<10} "
                f"{fraction:>8.0%} {job['created_at']}"
            )
    return 0


def _cancel(args: argparse.Namespace) -> int:
    with _client(args) as api:
        for job_id in args.ids:
            print(f"{job_id} {api.cancel(job_id)['status']}")
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
    remote = argparse.ArgumentParser(add_help=False)
    remote.add_argument(
        "--url",
        default=os.environ.get("MESHSERVICE_URL", "http://127.0.0.1:8000"),
        help="the service (MESHSERVICE_URL)",
    )
    remote.add_argument(
        "--key", default=os.environ.get("MESHSERVICE_API_KEY"), help="API key (MESHSERVICE_API_KEY)"
    )
    submit = commands.add_parser(
        "submit", parents=[remote], help="submit a batch of jobs (JSON or JSON-lines files)"
    )
    submit.add_argument("files", nargs="+", metavar="FILE")
    submit.add_argument("--wait", action="store_true", help="follow the jobs until they end")
    submit.add_argument("--out", metavar="DIR", help="download results into DIR (implies --wait)")
    submit.add_argument("--format", default="vtu", choices=sorted(FORMATS), help="mesh format")
    submit.set_defaults(func=_submit)
    jobs = commands.add_parser("jobs", parents=[remote], help="list your jobs, newest first")
    jobs.add_argument("--limit", type=int, default=50)
    jobs.set_defaults(func=_jobs)
    cancel = commands.add_parser("cancel", parents=[remote], help="cancel jobs")
    cancel.add_argument("ids", nargs="+", metavar="ID")
    cancel.set_defaults(func=_cancel)
    args = parser.parse_args(argv)
    if args.command is None:
        args = parser.parse_args(["serve", *(argv or sys.argv[1:])])
    try:
        return args.func(args)
    except ServiceError as exc:
        print(f"meshservice: {exc}", file=sys.stderr)
        return 1
