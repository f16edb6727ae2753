from pathlib import Path

import pytest

from _paths import DATA


def data_file(rel: str) -> Path:
    p = DATA / rel
    if not p.exists():
        pytest.skip(f"shared data file {rel} not found under {DATA}")
    return p


@pytest.fixture(scope="session")
def data():
    return data_file


@pytest.fixture(scope="session")
def stand():
    from lidartrees_gis.synthetic import make_stand

    return make_stand()
