"""Sensor calibration as PX4 SITL runs MAV_CMD_PREFLIGHT_CALIBRATION, on the simulated sensors.

Source: PX4 src/modules/commander/Commander.cpp (which parameter starts what, the ACKs),
calibration_messages.h (the "[cal] …" texts QGC's sensor page and MAVSDK's calibration plugin
parse), calibration_routines.cpp (detect_orientation, calibrate_from_orientation,
calibrate_cancel_check), accelerometer_calibration.cpp, mag_calibration.cpp,
gyro_calibration.cpp, level_calibration.cpp, esc_calibration.cpp.

Rules:
- One calibration at a time, disarmed only: armed or busy → TEMPORARILY_REJECTED. While one
  runs, arming is denied ("Arming denied: calibrating").
- Gyro, level horizon, barometer: "[cal] calibration started: 2 <kind>", "[cal] progress <N>"
  in steps of 10 over ``DURATION_S``, "[cal] calibration done: <kind>". The simulated sensors
  need no new offsets, so no parameter changes.
- Accelerometer and magnetometer run PX4's side-by-side routine on the vehicle's accelerometer
  and gyro samples (``sample``, the IMU's latest, at each 50 Hz tick): wait for the vehicle to
  rest, name the side it rests on, measure it (accel) or wait for it to be turned around it
  (mag). Nothing turns a disarmed simulated vehicle, so they end as on a PX4 SITL vehicle that
  nobody picks up: the accelerometer measures the "down" side, then fails after five more rests
  on it ("[cal] calibration failed: timeout: no motion"); the magnetometer fails after 35 s
  without rotation ("Failed: This calibration requires rotation.").
- Cancel (every parameter 0 while one runs) is answered twice, as in PX4, both through
  ``on_ack`` to the sender: the routine sees the command where PX4's routines check for it
  (their loops run at the sensors' rate; here at the next tick), says "[cal] calibration
  cancelled" and ACCEPTs it (calibrate_answer_command); Commander, whose worker is busy,
  answers TEMPORARILY_REJECTED at its next cycle (here: that tick, after the routine ran). A
  routine in a phase without the check (averaging a side) ACCEPTs later, so the rejection
  comes first there; MAVSDK and QGC take the first answer.
- Radio calibration (param4 1) only blocks arming until param4 0 ends it; ESC calibration is
  refused while the battery is connected, as always in simulation. Airspeed is not served.
- The quick accelerometer calibration (param5 4, do_accel_calibration_quick) prints no "started"
  text: for up to QUICK_READ_S it averages the resting accelerometer (restarted on a jump of
  0.5 m/s^2) until more than QUICK_SAMPLES IMU samples have a small variance, takes the closest
  of the six orientations as the truth, and ends "[cal] calibration done: accel" (the offset
  from that orientation within 0.9..1.1 g; the simulated sensors need none saved), or "[cal]
  calibration failed: accel" when the vehicle never rested.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Generator, Sequence

from vehicles.status_log import StatusLog
from vehicles.types import CommandResult

PREFLIGHT_CALIBRATION = 241  # MAV_CMD_PREFLIGHT_CALIBRATION
DURATION_S = 2.0
KINDS = ("gyro", "level", "baro", "accel", "mag", "accel_quick")
ORIENTED = ("accel", "mag", "accel_quick")  # the kinds that read the sensors (``sample``)

# detect_orientation_return, in PX4's order, and detect_orientation_str.
TAIL_DOWN, NOSE_DOWN, LEFT, RIGHT, UPSIDE_DOWN, RIGHTSIDE_UP, ORIENTATION_ERROR = range(7)
SIDES = ("back", "front", "left", "right", "up", "down")
ONE_G = 9.80665  # CONSTANTS_ONE_G
# What the accelerometer reads at rest on each side, in SIDES' order (the quick calibration's Y).
ORIENTATION_ACCEL = ((ONE_G, 0.0, 0.0), (-ONE_G, 0.0, 0.0), (0.0, ONE_G, 0.0),
                     (0.0, -ONE_G, 0.0), (0.0, 0.0, ONE_G), (0.0, 0.0, -ONE_G))

IMU_RATE_HZ = 250.0  # PX4's gz x500 IMU: sample counts below are in its samples
EMA_LEN_S = 0.5  # detect_orientation: EMA time constant
NORMAL_STILL_THR = 0.25
ACCEL_ERR_THR = 5.0  # m/s^2 from the axis an orientation expects
DETECT_TIMEOUT_S = 90.0
ACCEL_READ_S = 5.0  # read_accelerometer_avg: at most
ACCEL_READ_SAMPLES = 1000  # ... or until more samples than this with a small variance
ACCEL_MAX_VARIANCE = 0.01
ACCEL_ATTEMPTS = 10
QUICK_READ_S = 3.0  # do_accel_calibration_quick: at most
QUICK_SAMPLES = 300  # ... until more samples than this with a small variance
MAG_DURATION_S = 42.0  # calibraton_duration_seconds, over six sides
GYRO_INT_THRESH_RAD = 0.5

CAL_STARTED = "[cal] calibration started: 2 {}"
CAL_DONE = "[cal] calibration done: {}"
CAL_FAILED = "[cal] calibration failed: {}"
CAL_CANCELLED = "[cal] calibration cancelled"
CAL_PROGRESS = "[cal] progress <{}>"
CAL_ORIENTATION_DETECTED = "[cal] {} orientation detected"
CAL_SIDE_DONE = "[cal] {} side done, rotate to a different side"

OK, ERROR, CANCELLED = "ok", "error", "cancelled"  # calibrate_return

Routine = Generator[None, None, str]


class Calibration:
    def __init__(self, log: StatusLog) -> None:
        self.log = log
        self.kind: str | None = None
        self.rc_in_progress = False
        self._routine: Routine | None = None
        self._now = 0.0
        self._accel: Sequence[float] = (0.0, 0.0, -ONE_G)
        self._gyro: Sequence[float] = (0.0, 0.0, 0.0)
        self._cancel = False
        self._cancel_source = (0, 0)
        self._reject_pending = False  # Commander's TEMPORARILY_REJECTED of a cancel, not sent yet
        # (now, command, result, (sysid, compid) answered): the routines' own COMMAND_ACKs
        self.on_ack: Callable[[float, int, int, tuple[int, int]], None] | None = None

    @property
    def busy(self) -> bool:
        """A calibration runs, or a radio calibration is open: arming is denied."""
        return self.kind is not None or self.rc_in_progress

    @property
    def needs_sensors(self) -> bool:
        return self.kind in ORIENTED

    def start(self, now_s: float, kind: str, armed: bool) -> CommandResult:
        if armed or self.kind is not None:
            return CommandResult.TEMPORARILY_REJECTED
        self.kind, self._now, self._cancel = kind, now_s, False
        if kind != "accel_quick":
            self.log.info(now_s, CAL_STARTED.format(kind))
        routine = {"accel": self._accel_calibration, "mag": self._mag_calibration,
                   "accel_quick": self._accel_quick}.get(kind)
        self._routine = routine() if routine else self._timed(kind)
        return CommandResult.ACCEPTED

    def cancel(self, now_s: float, source: tuple[int, int] = (0, 0)) -> CommandResult | None:
        """PREFLIGHT_CALIBRATION with every parameter 0 from ``source``: cancels a running
        calibration (module rules), ends a radio calibration; else nothing to do."""
        if self.kind is not None:
            self._cancel, self._cancel_source, self._reject_pending = True, source, True
            return None  # both answers come from ``update`` (module rules)
        if self.rc_in_progress:
            self.rc_in_progress = False
            self.log.info(now_s, "Calibration: Restoring RC input")
        return CommandResult.ACCEPTED

    def start_radio(self, now_s: float, armed: bool) -> CommandResult:
        if armed or self.kind is not None:
            return CommandResult.TEMPORARILY_REJECTED
        self.rc_in_progress = True
        self.log.info(now_s, "Calibration: Disabling RC input")
        return CommandResult.ACCEPTED

    def start_esc(self, now_s: float, armed: bool) -> CommandResult:
        """check_battery_disconnected: the simulated battery is always connected."""
        if armed or self.kind is not None:
            return CommandResult.TEMPORARILY_REJECTED
        self.log.critical(now_s, CAL_FAILED.format("Disconnect battery and try again"))
        return CommandResult.DENIED

    def sample(self, accel_frd: Sequence[float], gyro_frd: Sequence[float]) -> None:
        """The IMU's latest specific force (m/s^2) and rates (rad/s), FRD (sensor_combined)."""
        self._accel, self._gyro = accel_frd, gyro_frd

    def update(self, now_s: float) -> None:
        if self._routine is not None:
            self._now = now_s
            try:
                next(self._routine)
            except StopIteration:
                self.kind = self._routine = None
        if self._reject_pending:
            self._reject_pending = False
            if self.on_ack is not None:
                self.on_ack(now_s, PREFLIGHT_CALIBRATION, int(CommandResult.TEMPORARILY_REJECTED),
                            self._cancel_source)

    # --- the routines: generators resumed once per tick, as PX4's worker thread's loops -------
    def _sleep(self, seconds: float) -> Generator[None, None, None]:
        until = self._now + seconds
        while self._now < until:
            yield

    def _cancelled(self) -> bool:
        """calibrate_cancel_check."""
        if self._cancel:
            self._cancel = False
            if self.on_ack is not None:  # the ACK before the text: MAVSDK's cancel() waits
                self.on_ack(self._now, PREFLIGHT_CALIBRATION, int(CommandResult.ACCEPTED),
                            self._cancel_source)  # for it and holds the text's lock meanwhile
            self.log.critical(self._now, CAL_CANCELLED)
            return True
        return False

    def _timed(self, kind: str) -> Routine:
        """Gyro, level horizon, barometer: progress over DURATION_S, then done."""
        t0, progress = self._now, -1
        while True:
            if self._cancelled():
                return CANCELLED
            pct = min(100, int((self._now - t0) / DURATION_S * 100.0) // 10 * 10)
            while progress < pct:
                progress += 10 if progress >= 0 else 1
                self.log.info(self._now, CAL_PROGRESS.format(progress))
            if pct >= 100:
                self.log.info(self._now, CAL_DONE.format(kind))
                return OK
            yield

    def _detect_orientation(self, lenient: bool) -> Generator[None, None, int]:
        """Wait until the accelerometer has been still for a while; the side it rests on."""
        still_thr2 = (NORMAL_STILL_THR * 3 if lenient else NORMAL_STILL_THR) ** 2
        still_time_s = 0.5 if lenient else 1.3
        ema, disp = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        t_prev = t_timeout = self._now
        t_timeout += DETECT_TIMEOUT_S
        t_still: float | None = None
        overdue_samples = 0.0
        while True:
            yield
            t = self._now
            w = (t - t_prev) / EMA_LEN_S
            for i in range(3):
                d = self._accel[i] - ema[i]
                ema[i] += d * w
                disp[i] *= 1.0 - w
                disp[i] = max(disp[i], min(d * d, still_thr2 * 8.0))
            if max(disp) < still_thr2:
                if t_still is None:
                    self.log.info(t, "[cal] detected rest position, hold still...")
                    t_still, t_timeout = t, t + DETECT_TIMEOUT_S
                elif t > t_still + still_time_s:
                    break
            elif max(disp) > still_thr2 * 4.0 and t_still is not None:
                self.log.info(t, "[cal] detected motion, hold still...")
                yield from self._sleep(0.2)
                t_still = None
            if t > t_timeout:
                overdue_samples += (t - t_prev) * IMU_RATE_HZ
                if overdue_samples > 1000:
                    self.log.critical(t, CAL_FAILED.format("reading sensor"))
                    return ORIENTATION_ERROR
            t_prev = t
        for side, axis, sign in ((TAIL_DOWN, 0, 1), (NOSE_DOWN, 0, -1), (LEFT, 1, 1),
                                 (RIGHT, 1, -1), (UPSIDE_DOWN, 2, 1), (RIGHTSIDE_UP, 2, -1)):
            if all(abs(ema[i] - (sign * ONE_G if i == axis else 0.0)) < ACCEL_ERR_THR
                   for i in range(3)):
                return side
        self.log.critical(self._now, "ERROR: invalid orientation")
        return ORIENTATION_ERROR

    def _from_orientation(self, collected: list[bool], worker, lenient: bool) -> Routine:
        """calibrate_from_orientation: visit every side not yet collected."""
        failures = 0
        while True:
            if self._cancelled():
                return CANCELLED
            if failures > 4:
                self.log.critical(self._now, CAL_FAILED.format("timeout: no motion"))
                return ERROR
            if all(collected):
                return OK
            pending = "".join(f" {SIDES[i]}" for i in range(6) if not collected[i])
            self.log.info(self._now, f"[cal] pending:{pending}")
            yield from self._sleep(0.02)
            self.log.info(self._now, "[cal] hold vehicle still on a pending side")
            yield from self._sleep(0.02)
            orient = yield from self._detect_orientation(lenient)
            if orient == ORIENTATION_ERROR:
                failures += 1
                self.log.info(self._now, "[cal] detected motion, hold still...")
                yield from self._sleep(0.02)
                continue
            if collected[orient]:
                failures += 1
                self.log.info(self._now, f"[cal] {SIDES[orient]} side already completed")
                yield from self._sleep(0.02)
                continue
            for _ in range(2):
                self.log.info(self._now, CAL_ORIENTATION_DETECTED.format(SIDES[orient]))
                yield from self._sleep(0.02)
            failures = 0
            result = yield from worker(orient)
            if result != OK:
                return result
            for _ in range(2):
                self.log.info(self._now, CAL_SIDE_DONE.format(SIDES[orient]))
                yield from self._sleep(0.02)
            collected[orient] = True
            yield from self._sleep(0.2)

    def _accel_calibration(self) -> Routine:
        """do_accel_calibration (CAL_ACC_SIDES: all six)."""
        done = [0]
        sides: list[tuple[float, float, float] | None] = [None] * 6

        def worker(orient: int) -> Routine:
            for _ in range(ACCEL_ATTEMPTS):
                self.log.info(self._now, f"[cal] Hold still, measuring {SIDES[orient]} side")
                mean = yield from self._read_accel_avg()
                if mean is not None:
                    sides[orient] = mean
                    self.log.info(self._now, f"[cal] {SIDES[orient]} side result: "
                                             f"[{mean[0]:.3f} {mean[1]:.3f} {mean[2]:.3f}]")
                    done[0] += 1
                    self.log.info(self._now, CAL_PROGRESS.format(17 * done[0]))
                    return OK
            return ERROR

        result = yield from self._from_orientation([False] * 6, worker, lenient=False)
        # Six sides would need the vehicle turned over by hand; with the simulated sensors'
        # scale exact there would be no new scale factors to save, as for the gyro.
        if result == OK:
            self.log.info(self._now, CAL_DONE.format("accel"))
        else:
            self.log.critical(self._now, CAL_FAILED.format("accel"))
        yield from self._sleep(0.6)  # "give this message enough time to propagate"
        return result

    def _accel_quick(self) -> Routine:
        """do_accel_calibration_quick (module rules)."""
        mean = yield from self._read_accel_avg(QUICK_READ_S, QUICK_SAMPLES, until_valid=True)
        ok = False
        if mean is not None:
            down = min(ORIENTATION_ACCEL, key=lambda y: math.dist(y, mean))
            offset = [m - y for m, y in zip(mean, down)]
            corrected = math.dist(mean, offset) if all(map(math.isfinite, offset)) else math.nan
            ok = 0.9 * ONE_G < corrected <= 1.1 * ONE_G
        if ok:
            self.log.info(self._now, CAL_DONE.format("accel"))
            return OK
        self.log.critical(self._now, CAL_FAILED.format("accel"))
        return ERROR

    def _read_accel_avg(self, read_s: float = ACCEL_READ_S, min_samples: int = ACCEL_READ_SAMPLES,
                        until_valid: bool = False
                        ) -> Generator[None, None, tuple[float, float, float] | None]:
        """read_accelerometer_avg: a Welford mean of the resting accelerometer, restarted on a
        jump of 0.5 m/s^2; done after ``min_samples`` IMU samples with a small variance, or
        ``read_s``. None: too noisy (``until_valid``: not yet valid when ``read_s`` ran out)."""
        t0 = t_prev = self._now
        prev = (0.0, 0.0, 0.0)
        n, mean, m2, samples = 0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0.0
        valid = False
        while self._now - t0 < read_s:
            yield
            a = self._accel
            samples += (self._now - t_prev) * IMU_RATE_HZ
            t_prev = self._now
            if math.dist(a, prev) > 0.5:
                n, mean, m2, samples = 0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0.0
                prev = (a[0], a[1], a[2])
                continue
            n += 1
            for i in range(3):
                d = a[i] - mean[i]
                mean[i] += d / n
                m2[i] += d * (a[i] - mean[i])
            if n > 1 and samples > min_samples and _variance_ok(m2, n):
                valid = True
                break
        if (valid or not until_valid) and n > 1 and _variance_ok(m2, n):
            return mean[0], mean[1], mean[2]
        return None

    def _mag_calibration(self) -> Routine:
        """do_mag_calibration (CAL_MAG_SIDES: all six), lenient still detection."""
        per_side_s = MAG_DURATION_S / 6

        def worker(orient: int) -> Routine:
            self.log.info(self._now, "[cal] Rotate vehicle")  # mag_calibration_worker, v1.11+
            deadline = self._now + per_side_s * 5
            integral, last = [0.0, 0.0, 0.0], self._now
            while max(abs(x) for x in integral) < GYRO_INT_THRESH_RAD:
                if self._cancelled():
                    return CANCELLED
                if self._now > deadline:
                    self.log.critical(self._now, "Failed: This calibration requires rotation.")
                    return ERROR
                yield
                for i in range(3):
                    integral[i] += self._gyro[i] * (self._now - last)
                last = self._now
            # Turning a disarmed simulated vehicle 0.5 rad takes a hand; the samples it would
            # then collect (and the sphere fit) are not modelled, so the side cannot complete.
            self.log.critical(self._now, CAL_FAILED.format("reading sensor"))
            return ERROR

        result = yield from self._from_orientation([False] * 6, worker, lenient=True)
        if result == OK:
            self.log.info(self._now, CAL_PROGRESS.format(100))
            self.log.info(self._now, CAL_DONE.format("mag"))
        elif result == ERROR:
            self.log.critical(self._now, CAL_FAILED.format("mag"))
        yield from self._sleep(0.6)
        return result


def _variance_ok(m2: list[float], n: int) -> bool:
    """WelfordMean: the variance vector's length within ACCEL_MAX_VARIANCE."""
    return math.hypot(*(x / (n - 1) for x in m2)) <= ACCEL_MAX_VARIANCE
