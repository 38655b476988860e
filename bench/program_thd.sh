#!/usr/bin/env bash
# The transducer's own THD on the card path, bare plant (no model active): docs/engine.md's JACK-dummy recipe —
# a JACK server with the dummy driver, `panelbass transducer --jack --thd-log`, `serve --backend alsa` wired to
# it — then PUT /api/program sines at 0.1 / 0.2 / 0.3 for each frequency, HOLD seconds each. One table row per
# sine: the log's windows that lie wholly inside its hold (after the 50 ms fade), their median drive fundamental,
# the noise-free acceleration's THD (harmonics 2..5), the sensor's fundamental, THD (noise share out) and floor.
# Usage: bash bench/program_thd.sh [FREQUENCIES] [PLANT]   (default "80" and panel-exciter; table on stdout)
# Example: HOLD=6 bash bench/program_thd.sh "40 80 160"
# PANELBASS_BIN overrides the binary; KEEP=DIR keeps the log and the servers' output. About 20 s per frequency.
set -euo pipefail
FREQS=${1:-80}
PLANT=${2:-panel-exciter}
HOLD=${HOLD:-6}
B=$(realpath "${PANELBASS_BIN:-build/bin/panelbass}")
W=$(mktemp -d)
[ -n "${KEEP:-}" ] && mkdir -p "$KEEP" && W=$(realpath "$KEEP")
cd "$W"
export JACK_NO_AUDIO_RESERVATION=1 JACK_DEFAULT_SERVER=pbthd$$
PORT=$((20000 + $$ % 20000))
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done; }
trap cleanup EXIT
rm -f thd.jsonl marks.txt
jackd --no-realtime -S -n "$JACK_DEFAULT_SERVER" -d dummy -r 48000 -p 64 > jackd.log 2>&1 &
pids=($! "${pids[@]}")
sleep 1.5
"$B" transducer --jack --plant "$PLANT" --name tr --thd-log thd.jsonl > transducer.json 2> transducer.err &
pids=($! "${pids[@]}")
sleep 1
cat > card.conf <<'END'
pcm.pb_play    { type jack name "pb_play"
                 playback_ports { 0 "tr:drive" 1 "system:playback_1" } }
pcm.pb_capture { type jack name "pb_capture"
                 capture_ports { 0 "tr:sensor" 1 "pb_play:out_000" 2 "tr:current" } }
END
rm -rf store
"$B" serve --backend alsa --alsa-config card.conf --playback pb_play --capture pb_capture \
    --capture-channels 3 --sensor-channel 0 --loopback-channel 1 --current-channel 2 --periods 8 --no-demo \
    --port "$PORT" --store store --web "" > serve.out 2> serve.err &
pids=($! "${pids[@]}")
until grep -qs serving serve.out; do sleep 0.2; done
sleep 1
for f in $FREQS; do
  for a in 0.1 0.2 0.3; do
    echo "$(date +%s.%N) $f $a" >> marks.txt
    curl -fsS -X PUT "localhost:$PORT/api/program" -d "{\"signal\":\"sine:$f\",\"amplitude\":$a}" > /dev/null
    sleep "$HOLD"
  done
done
echo "$(date +%s.%N) end end" >> marks.txt
cleanup
pids=()
python3 - <<'PY'
import json, statistics as st
marks = [l.split() for l in open('marks.txt')]
lines = [json.loads(l) for l in open('thd.jsonl')]
print('| sine | program | windows | drive fundamental | THD noise-free % | sensor fundamental (V) | sensor THD % | sensor floor % |')
print('|---|---|---|---|---|---|---|---|')
for (t0, f, a), (t1, _, _) in zip(marks, marks[1:]):
    t0, t1 = float(t0), float(t1)
    # a line is written within ~0.1 s of its window's end; the window (1 s) must start after the change and its fade
    w = [l for l in lines if l['unix_time_s'] - 1.05 > t0 + 0.1 and l['unix_time_s'] < t1 and l['thd_clean_pct'] is not None]
    if not w:
        print(f'| {f} Hz | {a} | 0 | | | | | |')
        continue
    med = lambda k: st.median(l[k] for l in w)
    c = [l['thd_clean_pct'] for l in w]
    print(f"| {f} Hz | {a} | {len(w)} | {med('drive_fundamental'):.4f} | {st.median(c):.3f} ({min(c):.3f}–{max(c):.3f}) | "
          f"{med('sensor_fundamental'):.4f} | {med('thd_sensor_pct'):.2f} | {med('thd_sensor_floor_pct'):.2f} |")
PY
