"""Prometheus metrics: jobs by status, queue depth, job durations.

Each app has its own collector registry, so several apps can live in one
process (tests) without clashing.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

from prometheus_client import CollectorRegistry, Histogram, generate_latest
from prometheus_client.core import GaugeMetricFamily
from prometheus_client.registry import Collector


class _StoreCollector(Collector):
    def __init__(self, counts: Callable[[], dict[str, int]]) -> None:
        self._counts = counts

    def collect(self) -> Iterator[GaugeMetricFamily]:
        counts = self._counts()
        jobs = GaugeMetricFamily(
            "meshservice_jobs", "Jobs in the store by status", labels=["status"]
        )
        for status, n in counts.items():
            jobs.add_metric([status], n)
        yield jobs
        yield GaugeMetricFamily(
            "meshservice_queue_depth", "Jobs waiting to run", value=counts.get("queued", 0)
        )


class Metrics:
    """The service's metrics, rendered in the Prometheus text format."""

    def __init__(self, counts: Callable[[], dict[str, int]]) -> None:
        self.registry = CollectorRegistry()
        self.registry.register(_StoreCollector(counts))
        self.job_duration = Histogram(
            "meshservice_job_duration_seconds",
            "Wall time of job runs, from start to end",
            ["method", "status"],
            registry=self.registry,
            buckets=(0.01, 0.03, 0.1, 0.3, 1, 3, 10, 30, 100, 300, 1000),
        )

    def render(self) -> bytes:
        return generate_latest(self.registry)
