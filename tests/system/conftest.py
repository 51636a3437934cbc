"""Fixtures the system tests share."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.system.nullmodem import NullModem


@pytest.fixture
def modem() -> Iterator[NullModem]:
    """Two pseudo-terminals joined by a relay thread: ``modem.ends`` are the two device paths."""
    link = NullModem()
    yield link
    link.close()
