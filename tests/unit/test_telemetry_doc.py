"""docs/telemetry.md's table is the stream table (gateway/mavlink/streams.py STREAMS)."""

from pathlib import Path

from pymavlink.dialects.v20 import development as M  # common and CURRENT_MODE

from gateway.mavlink.streams import STREAMS
from gateway.mavlink.wip_dialect import (
    ESC_INFO,
    ESC_STATUS,
    LINK_NODE_STATUS,
    TIME_ESTIMATE_TO_TARGET,
)

DOC = Path(__file__).resolve().parents[2] / "docs" / "telemetry.md"


def test_the_documented_rates_are_the_streams():
    rows = []
    for line in DOC.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 4 and cells[0].isupper() and cells[1] not in ("---",):
            rows.append((cells[0], float(cells[1]), float(cells[2])))
    wip = {"ESC_INFO": ESC_INFO.id, "ESC_STATUS": ESC_STATUS.id,
           "TIME_ESTIMATE_TO_TARGET": TIME_ESTIMATE_TO_TARGET.id,
           "LINK_NODE_STATUS": LINK_NODE_STATUS.id}  # pymavlink leaves them out
    ids = {name: wip.get(name) or getattr(M, f"MAVLINK_MSG_ID_{name}") for name, _, _ in rows}
    assert [(ids[n], g, a) for n, g, a in rows] == [
        (s.msg_id, s.gcs_hz, s.api_hz) for s in STREAMS]
