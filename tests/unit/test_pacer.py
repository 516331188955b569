

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
