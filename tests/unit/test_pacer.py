

def test_arrival_moves_the_clock_but_never_runs_due_work():
    from gateway.daemon.pacer import Pacer
    from netsim.kernel import Kernel

    k = Kernel()
    ran = []
    wall = [0.0]
    p = Pacer(k, clock=lambda: wall[0])
    k.schedule(0.010, ran.append, "due")
    wall[0] = 0.004
    p.sync_arrival()
    assert k.now == 0.004 and not ran  # nothing due before the arrival: stamped exactly
    wall[0] = 0.015
    p.sync_arrival()
    assert k.now == 0.004 and not ran  # work is due: stamped at the present time, run later
    p.sync()
    assert k.now == wall[0] and ran == ["due"]


def test_a_pacer_waiting_at_its_horizon_ends_when_cancelled_as_the_horizon_moves():
    # A shard's last grant and its stop arrive together: the horizon moves and the pacer's
    # task is cancelled in the same turn of the loop; the cancel must still end it.
    import asyncio

    from gateway.daemon.pacer import Pacer
    from netsim.kernel import Kernel

    async def main() -> None:
        p = Pacer(Kernel())
        p.set_horizon(0.0)
        task = asyncio.create_task(p.run())
        for _ in range(5):
            await asyncio.sleep(0)  # the pacer now waits for its horizon to move
        p.set_horizon(0.03)
        task.cancel()
        done, _ = await asyncio.wait({task}, timeout=1.0)
        assert task in done and task.cancelled()

    asyncio.run(main())
