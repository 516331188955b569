"""The vehicle's command journal (vehicle_command / vehicle_command_ack for the logger)."""

from vehicles.command_journal import KEEP, CommandJournal

P7 = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def test_records_are_numbered_and_read_after_a_number():
    journal = CommandJournal()
    assert journal.after(0) == []
    journal.record(1.0, 400, P7, (245, 190), 0)
    journal.record(2.0, 22, P7, (245, 190), None)
    assert [r.command for r in journal.after(0)] == [400, 22]
    assert [r.seq for r in journal.after(1)] == [2] and journal.after(2) == []
    assert journal.after(1)[0].result is None


def test_only_the_newest_are_kept():
    journal = CommandJournal()
    for k in range(KEEP + 10):
        journal.record(float(k), 511, P7, (1, 1), 0)
    kept = journal.after(0)
    assert len(kept) == KEEP and kept[0].seq == 11 and kept[-1].seq == KEEP + 10
