"""Times as the sessions database keeps them: timezone-aware UTC (SQLite hands them back naive)."""

from __future__ import annotations

from datetime import UTC, datetime


def aware(value: datetime | None) -> datetime | None:
    if value is None:
        return None
    return value if value.tzinfo else value.replace(tzinfo=UTC)


def iso(value: datetime | None) -> str | None:
    """ISO 8601 with its UTC offset, or None."""
    return None if value is None else aware(value).isoformat()


def parse_iso(value: str | None) -> datetime | None:
    return None if value is None else aware(datetime.fromisoformat(value))


def epoch(value: datetime) -> float:
    return aware(value).timestamp()
