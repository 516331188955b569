

def test_arrival_sync_catches_up_a_little_never_a_burst():
    from gateway.pacer import ARRIVAL_SYNC_MAX_LAG_S, Pacer
    from netsim.kernel import Kernel

    k = Kernel()
    wall = [0.0]
    p = Pacer(k, clock=lambda: wall[0])
    wall[0] = ARRIVAL_SYNC_MAX_LAG_S / 2
    p.sync_arrival()
    assert k.now == wall[0]  # on time: the arrival is stamped exactly
    wall[0] += 0.15
    p.sync_arrival()
    assert k.now == ARRIVAL_SYNC_MAX_LAG_S / 2  # behind: left to the pacer's loop
    p.sync()
    assert k.now == wall[0]
