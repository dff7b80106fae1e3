"""The test server: the product app plus the testing methods, under a real uvicorn.

Run as ``python -m tests.service.server --port P --data-dir D`` with
``MESHSERVICE_*`` variables for the rest.
"""

from __future__ import annotations

import argparse

import uvicorn

from service.app import create_app
from service.settings import Settings
from tests.service.testing_methods import testing_registry


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--data-dir", required=True)
    args = parser.parse_args()
    settings = Settings(port=args.port, data_dir=args.data_dir)
    app = create_app(settings, testing_registry())
    uvicorn.run(
        app,
        host=settings.host,
        port=settings.port,
        log_level="warning",
        timeout_graceful_shutdown=5,
        timeout_keep_alive=settings.keep_alive,
    )


if __name__ == "__main__":
    main()
