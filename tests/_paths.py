"""Where the tests find the shared real data (``LIDARTREES_DATA`` or ../shared/data)."""
import os
from pathlib import Path

DATA = Path(os.environ.get("LIDARTREES_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data")).resolve()
