"""The events protocol's messages (common.xml: EVENT 410, CURRENT_EVENT_SEQUENCE 411,
REQUEST_EVENT 412, RESPONSE_EVENT_ERROR 413), which pymavlink 2.4.50's common dialect lacks.

Each is made by ``wip_dialect.define_message`` as mavgen makes a message class (wire order by
field size, CRC_EXTRA from the definition; tests/unit/test_events.py recomputes it) and
registered in the common and development dialects, so that pymavlink's parser decodes them with
their CRC checked and the encoder (codec.py) packs them like any other message. Importing this
module registers them.
"""

from __future__ import annotations

from gateway.mavlink.wip_dialect import U8, U16, U32, define_message

EVENT = define_message(410, "EVENT", 160, (
    (U8, "destination_component", 0), (U8, "destination_system", 0), (U32, "id", 0),
    (U32, "event_time_boot_ms", 0), (U16, "sequence", 0), (U8, "log_levels", 0),
    (U8, "arguments", 40)))
CURRENT_EVENT_SEQUENCE = define_message(411, "CURRENT_EVENT_SEQUENCE", 106, (
    (U16, "sequence", 0), (U8, "flags", 0)))
REQUEST_EVENT = define_message(412, "REQUEST_EVENT", 33, (
    (U8, "target_system", 0), (U8, "target_component", 0), (U16, "first_sequence", 0),
    (U16, "last_sequence", 0)))
RESPONSE_EVENT_ERROR = define_message(413, "RESPONSE_EVENT_ERROR", 77, (
    (U8, "target_system", 0), (U8, "target_component", 0), (U16, "sequence", 0),
    (U16, "sequence_oldest_available", 0), (U8, "reason", 0)))
