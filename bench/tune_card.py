#!/usr/bin/env python3
"""Tune through a sound card with no sound card, judged from the transducer's side (issue #56).

For each plant: a JACK server with the dummy driver, `panelbass transducer --jack --plant P --thd-log` and
`panelbass serve --backend alsa` wired as docs/engine.md wires them; one `tune` job with its defaults (or
--sensor-kind); then, when it kept its filter, `PUT /api/program` sines at each probe and program level, the THD
read from the transducer's own log (its noise-free acceleration), with the filter active and with it bypassed at
the program amplitude whose output fundamental (the log's) matches — the cut at equal output level. A level where
the chain's limiter acts is not reachable. Prints a Markdown table (and --json writes the figures).

--bare: no tune (no model active: the chain is its band-pass and limiter); each sine is held --hold seconds and
the log's windows wholly inside the hold (after the fade) give one row: their median drive fundamental, the
noise-free acceleration's THD (median, min–max), the sensor's fundamental, THD (the noise's share out) and floor.

  bench/tune_card.py --plants panel-exciter,tests/support/plants/panel-exciter-le-x.json --variants 2
  bench/tune_card.py --bare --frequencies 40,80,160 --hold 6
  bench/tune_card.py --no-sensor --realtime --plants panel-exciter   (a card with the loopback and the current only)
  (PANELBASS_BIN names another binary; a rig takes about 3 minutes a plant in real time, --bare 20 s a frequency.)
"""
import argparse, json, math, os, signal, socket, statistics, subprocess, sys, tempfile, time, urllib.request

BIN = os.environ.get('PANELBASS_BIN') or os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'build', 'bin', 'panelbass')
CARD_CONF = """pcm.pb_play    {{ type jack name "pb_play"
                 playback_ports {{ 0 "{t}:drive" 1 "system:playback_1" }} }}
pcm.pb_capture {{ type jack name "pb_capture"
                 capture_ports {{ 0 "{t}:sensor" 1 "pb_play:out_000" 2 "{t}:current" }} }}
"""
# Klippel's current-only configuration: the card captures the loopback and the coil current, no sensor
CARD_CONF_NO_SENSOR = """pcm.pb_play    {{ type jack name "pb_play"
                 playback_ports {{ 0 "{t}:drive" 1 "system:playback_1" }} }}
pcm.pb_capture {{ type jack name "pb_capture"
                 capture_ports {{ 0 "pb_play:out_000" 1 "{t}:current" }} }}
"""


def free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


class Rig:
    """jackd (dummy) + the transducer client + serve --backend alsa, in a folder of their own."""

    def __init__(self, plant, folder, window, periods=8, realtime=False, sensor=True, quality='low-latency'):
        self.folder, self.window, self.procs = folder, window, []
        self.server = f'pbtc{os.getpid()}'
        env = dict(os.environ, JACK_NO_AUDIO_RESERVATION='1', JACK_DEFAULT_SERVER=self.server)
        self.env = env
        # --realtime: the JACK server and its clients' process threads at SCHED_FIFO (a machine busy with builds
        # otherwise makes the dummy driver run late: thousands of xruns, and measurements interrupted)
        mode = ['-R', '-P', '60'] if realtime else ['--no-realtime']
        self.start(['jackd', *mode, '-S', '-n', self.server, '-d', 'dummy', '-r', '48000', '-p', '64'], 'jack.log')
        time.sleep(1.5)
        self.log = os.path.join(folder, 'thd.jsonl')
        self.start([BIN, 'transducer', '--jack', '--plant', plant, '--name', 'tr', '--thd-log', self.log,
                    '--thd-window', str(window)], 'transducer.log')
        time.sleep(1.0)
        conf = os.path.join(folder, 'card.conf')
        with open(conf, 'w') as f:
            f.write((CARD_CONF if sensor else CARD_CONF_NO_SENSOR).format(t='tr'))
        self.port = free_port()
        channels = (['--capture-channels', '3', '--sensor-channel', '0', '--loopback-channel', '1', '--current-channel', '2']
                    if sensor else ['--capture-channels', '2', '--loopback-channel', '0', '--current-channel', '1'])
        self.start([BIN, 'serve', '--port', str(self.port), '--store', os.path.join(folder, 'store'), '--backend', 'alsa',
                    '--alsa-config', conf, '--playback', 'pb_play', '--capture', 'pb_capture', *channels,
                    '--periods', str(periods), '--quality', quality, '--no-demo', '--web', ''], 'serve.log')
        for _ in range(100):
            try:
                if self.call('GET', '/api/status')['engine']['device']['state'] == 'running':
                    time.sleep(3)  # the ALSA jack plugin's ports connected and the loop settled
                    return
            except Exception:
                pass
            time.sleep(0.2)
        raise RuntimeError('the server did not start: ' + open(os.path.join(folder, 'serve.log')).read()[-2000:])

    def start(self, argv, log):
        out = open(os.path.join(self.folder, log), 'w')
        self.procs.append(subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT, env=self.env))

    def call(self, method, path, body=None):
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(f'http://127.0.0.1:{self.port}{path}', data=data, method=method,
                                     headers={'Content-Type': 'application/json'})
        with urllib.request.urlopen(req, timeout=600) as r:
            return json.loads(r.read() or b'null')

    def lines_after(self, t0, count):
        """The next `count` log lines whose window began after t0 (unix time)."""
        deadline = time.time() + 10 + count * self.window * 3
        while time.time() < deadline:
            rows = []
            with open(self.log) as f:
                for line in f:
                    row = json.loads(line)
                    if row.get('thd_clean_pct') is None or not row.get('clean_fundamental'):
                        continue  # a window with no fundamental to read (the fade, silence)
                    if row['unix_time_s'] - row['window_frames'] / 48000.0 >= t0:
                        rows.append(row)
            if len(rows) >= count:
                return rows[:count]
            time.sleep(self.window / 2)
        raise RuntimeError('the transducer wrote no THD log lines')

    def close(self):
        for p in reversed(self.procs):
            p.send_signal(signal.SIGINT)
        for p in reversed(self.procs):
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()


def reading(rig, frequency, amplitude, settle):
    """Plays sine:f at `amplitude`; the log's clean fundamental and THD (two windows' mean), and the limiter's share."""
    rig.call('PUT', '/api/program', {'signal': f'sine:{frequency:g}', 'amplitude': amplitude})
    t0 = time.time() + settle
    try:
        rows = rig.lines_after(t0, 2)
    except RuntimeError:
        rows = []  # no window with the fundamental: a limiter that acts says why (not reachable), else it is an error
    limited = rig.call('GET', '/api/status')['metrics'].get('limited_fraction', 0) or 0
    if not rows:
        if limited > 0:
            return None, None, limited
        raise RuntimeError(f'the transducer logged no window with a fundamental at sine:{frequency:g} {amplitude:g}')
    fundamental = sum(r['clean_fundamental'] for r in rows) / len(rows)
    thd = sum(r['thd_clean_pct'] for r in rows) / len(rows)
    return fundamental, thd, limited


def measure_cuts(rig, frequencies, levels, settle):
    points = []
    for f in frequencies:
        for a in levels:
            rig.call('PATCH', '/api/config', {'feedforward': {'bypass': False}})
            out_c, thd_c, limited = reading(rig, f, a, settle)
            point = {'frequency_hz': f, 'program_level': a, 'chain_thd_pct': thd_c, 'output': out_c}
            if limited > 0:
                point['reachable'] = False
                points.append(point)
                continue
            rig.call('PATCH', '/api/config', {'feedforward': {'bypass': True}})
            b = a
            for _ in range(5):
                out_b, thd_b, _ = reading(rig, f, b, settle)
                ratio = out_c / out_b
                if abs(20 * math.log10(ratio)) < 0.1:
                    break
                b = min(1.0, b * ratio)
            point.update(reachable=abs(20 * math.log10(out_c / out_b)) < 0.2, plant_drive=b, plant_thd_pct=thd_b,
                         cut_db=20 * math.log10(thd_b / thd_c) if thd_c > 0 else None)
            points.append(point)
    rig.call('PATCH', '/api/config', {'feedforward': {'bypass': False}})
    rig.call('PUT', '/api/program', {'signal': 'silence', 'amplitude': 0})
    return points


def bare_rows(rig, frequencies, levels, hold):
    """Each sine held `hold` s with no model active; one row of the log's windows wholly inside each hold."""
    marks = []
    for f in frequencies:
        for a in levels:
            rig.call('PUT', '/api/program', {'signal': f'sine:{f:g}', 'amplitude': a})
            marks.append((time.time(), f, a))
            time.sleep(hold)
    marks.append((time.time(), None, None))
    rig.call('PUT', '/api/program', {'signal': 'silence', 'amplitude': 0})
    with open(rig.log) as fh:
        lines = [json.loads(line) for line in fh]
    rows = []
    for (t0, f, a), (t1, _, _) in zip(marks, marks[1:]):
        # a line is written within ~0.1 s of its window's end; the window must start after the change and its fade
        inside = [l for l in lines if l['unix_time_s'] - rig.window - 0.1 > t0 + 0.1 and l['unix_time_s'] < t1
                  and l['thd_clean_pct'] is not None]
        row = {'frequency_hz': f, 'program_level': a, 'windows': len(inside)}
        if inside:
            med = lambda key: statistics.median(l[key] for l in inside)
            clean = [l['thd_clean_pct'] for l in inside]
            row.update(drive_fundamental=med('drive_fundamental'), thd_clean_pct=statistics.median(clean),
                       thd_clean_min_pct=min(clean), thd_clean_max_pct=max(clean),
                       sensor_fundamental=med('sensor_fundamental'), thd_sensor_pct=med('thd_sensor_pct'),
                       thd_sensor_floor_pct=med('thd_sensor_floor_pct'))
        rows.append(row)
    return rows


def print_bare(results):
    print('| plant | sine | program | windows | drive fundamental | THD noise-free % | sensor fundamental (V) | sensor THD % | sensor floor % |')
    print('|---|---|---|---|---|---|---|---|---|')
    for result in results:
        for r in result['rows']:
            head = f"| {result['plant']} | {r['frequency_hz']:g} Hz | {r['program_level']:g} | {r['windows']} |"
            if not r['windows']:
                print(head + ' | | | | |')
                continue
            print(head + f" {r['drive_fundamental']:.4f} | {r['thd_clean_pct']:.3f} ({r['thd_clean_min_pct']:.3f}–"
                  f"{r['thd_clean_max_pct']:.3f}) | {r['sensor_fundamental']:.4f} | {r['thd_sensor_pct']:.2f} | "
                  f"{r['thd_sensor_floor_pct']:.2f} |")


def tune(rig, params):
    t = time.time()
    job = rig.call('POST', '/api/jobs', {'kind': 'tune', 'params': params})
    while True:
        record = rig.call('GET', f"/api/jobs/{job['id']}")
        if record['state'] in ('succeeded', 'failed', 'cancelled'):
            return record, time.time() - t
        time.sleep(1)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--plants', default='panel-exciter', help='presets or plant files, comma-separated')
    ap.add_argument('--variants', type=int, default=0, help='also N ±20 %% variants of panel-exciter (seeds 1..N)')
    ap.add_argument('--sensor-kind', default='none', help="the tune's sensor_kind (none: the current alone)")
    ap.add_argument('--frequencies', default='40,80,160')
    ap.add_argument('--levels', default='0.1,0.2,0.3')
    ap.add_argument('--window', type=float, help="the transducer's THD window, s (0.5; --bare: 1)")
    ap.add_argument('--bare', action='store_true', help='no tune: the bare plant through the card, each sine held --hold s')
    ap.add_argument('--hold', type=float, default=6.0, help='--bare: how long each sine plays, s')
    ap.add_argument('--settle', type=float, default=0.4, help='after a program change, s')
    ap.add_argument('--periods', type=int, default=8, help="serve's device buffer, periods of 64 frames (16 on a loaded machine)")
    ap.add_argument('--json', help='write the figures here')
    ap.add_argument('--keep', help='keep the rigs\' folders under this folder')
    ap.add_argument('--realtime', action='store_true', help='run the JACK server (and its clients) in real-time mode')
    ap.add_argument('--quality', default='low-latency',
                    help="serve's resampler between the chain's rate and the card's (serve --quality)")
    ap.add_argument('--no-sensor', action='store_true',
                    help="the card captures no sensor (the loopback and the current only): tune keeps its filter unverified")
    a = ap.parse_args()
    if a.window is None:
        a.window = 1.0 if a.bare else 0.5
    frequencies = [float(x) for x in a.frequencies.split(',')]
    levels = [float(x) for x in a.levels.split(',')]
    plants = a.plants.split(',')
    base = a.keep or tempfile.mkdtemp(prefix='tune_card.')
    for n in range(1, a.variants + 1):
        path = os.path.join(base, f'panel-exciter-vary-{n}.json')
        os.makedirs(base, exist_ok=True)
        with open(path, 'w') as f:
            subprocess.run([BIN, 'plant', 'vary', 'panel-exciter', '--by', '0.2', '--seed', str(n)], stdout=f, check=True)
        plants.append(path)
    results = []
    for plant in plants:
        name = os.path.splitext(os.path.basename(plant))[0]
        folder = os.path.join(base, name)
        os.makedirs(folder, exist_ok=True)
        rig = Rig(plant, folder, a.window, a.periods, a.realtime, not a.no_sensor, a.quality)
        if a.bare:
            try:
                row = {'plant': name, 'rows': bare_rows(rig, frequencies, levels, a.hold)}
            finally:
                rig.close()
            results.append(row)
            print(json.dumps(row), file=sys.stderr)
            continue
        try:
            record, seconds = tune(rig, {'sensor_kind': a.sensor_kind})
            row = {'plant': name, 'tune_s': seconds, 'state': record['state']}
            if record['state'] == 'succeeded':
                r = record['result']
                row.update(kept=r['keep'], decision=r['decision'], current_j_val_pct=r['summary'].get('current_j_val_pct'),
                           drive=r['summary'].get('drive'), current_j_val_pct_by_drive=r['summary'].get('current_j_val_pct_by_drive'))
                if r['keep']:
                    row['points'] = measure_cuts(rig, frequencies, levels, a.settle)
            else:
                row['error'] = record.get('error')
        finally:
            rig.close()
        results.append(row)
        print(json.dumps(row), file=sys.stderr)
    if a.bare:
        print_bare(results)
    else:
        print_tune(results, frequencies, levels)
    if a.json:
        with open(a.json, 'w') as f:
            json.dump(results, f, indent=1)


def print_tune(results, frequencies, levels):
    print(f"| plant | tune | current J_val %, as sent / loopback (the fit's drive) | " + ' | '.join(f'{f:g} Hz cut, dB ({"/".join(f"{l:g}" for l in levels)})' for f in frequencies) + ' |')
    print('|---|---|---|' + '---|' * len(frequencies))
    for row in results:
        cells = []
        for f in frequencies:
            got = [p for p in row.get('points', []) if p['frequency_hz'] == f]
            cells.append(' / '.join('n.r.' if not p.get('reachable') else '–' if p['cut_db'] is None else f"{p['cut_db']:.1f}"
                                    for p in got) or '–')
        tune_cell = f"{row['tune_s']:.0f} s, " + ('kept' if row.get('kept') else 'left out' if row['state'] == 'succeeded' else 'failed')
        by = row.get('current_j_val_pct_by_drive') or {}
        j_cell = ' / '.join(f'**{by[d]:.4f}**' if row.get('drive') == d else f'{by[d]:.4f}' for d in ('as sent', 'loopback') if d in by)
        j = row.get('current_j_val_pct')
        print(f"| {row['plant']} | {tune_cell} | {j_cell or ('–' if j is None else f'{j:.4f}')} | " + ' | '.join(cells) + ' |')


if __name__ == '__main__':
    main()
