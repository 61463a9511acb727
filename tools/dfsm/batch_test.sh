#!/bin/bash
# dfsm batch over generated bursts, a burst.tar in a dfsmd job directory, a
# folder of images cut into windows and a burst that cannot be read: every one
# has a result and a summary line (ground truth scored), the exit status says
# one failed; --resume after kill -9 mid-run finishes the rest and redoes no
# finished burst; shards merged list what the whole batch lists, with the same
# calibrations; --calibrate-first gives every burst the joint camera as a
# checked prior. Usage: batch_test.sh DFSM WORKDIR
set -euo pipefail
dfsm="$1" work="$2"
rm -rf "$work" && mkdir -p "$work/in"
fail() {
  echo "FAIL: $1"
  [ -f "$work/log" ] && tail -30 "$work/log"
  exit 1
}
synth() { "$dfsm" synth --width 320 --height 240 --rotation 1 --supersampling 1 "$@" >/dev/null; }
for seed in 1 2 3 4; do synth --out "$work/in/burst-$seed" --seed "$seed"; done
synth --out "$work/job" --seed 5
mkdir -p "$work/in/job-5" "$work/clip"
tar -C "$work/job" -cf "$work/in/job-5/burst.tar" .
cp "$work/job"/frames/*.png "$work/clip/"
mkdir -p "$work/in/broken" && echo '{"format": "dfsm-burst/1"}' >"$work/in/broken/manifest.json"

# 1. Everything once: 5 bursts + 1 broken + 2 windows of the clip's 10 frames.
status=0
"$dfsm" batch "$work/in" "$work/clip" --windows 5 --out "$work/out" --jobs 2 >"$work/log" 2>&1 ||
  status=$?
[ "$status" -eq 1 ] || fail "a failed burst must give exit status 1, got $status"
summary="$work/out/summary.jsonl"
[ "$(wc -l <"$summary")" -eq 8 ] || fail "summary.jsonl does not list 8 bursts"
[ "$(grep -c '"status":"ok"' "$summary")" -eq 7 ] || fail "7 bursts should be ok"
grep '"name":"broken"' "$summary" | grep -q '"status":"failed"' || fail "the broken burst is not failed"
grep -q '"name":"clip-from-5"' "$summary" || fail "the clip's second window is missing"
grep '"name":"job-5"' "$summary" | grep -q '"abs_rel"' || fail "the tar's ground truth was not scored"
head -1 "$work/out/summary.csv" | grep -q '^name,input,status' || fail "summary.csv has no header"
[ "$(wc -l <"$work/out/summary.csv")" -eq 9 ] || fail "summary.csv does not have 8 rows"
for name in burst-1 burst-2 burst-3 burst-4 job-5 clip-from-0; do
  [ -s "$work/out/$name/depth.tiff" ] || fail "$name has no depth.tiff"
done
[ ! -e "$work/out/job-5/.burst" ] || fail "the extracted tar was left in the result"
[ -z "$(ls -A "$work/out/.partial" 2>/dev/null)" ] || fail "a partial result was left behind"

# dfsm show: a result in a few lines, with scores; a failed one says why.
"$dfsm" show "$work/out/burst-1" --truth "$work/in/burst-1" >"$work/show" || fail "show failed"
grep -q "^calibration f .* px (sigma" "$work/show" && grep -q "^scores      f .*depth AbsRel" "$work/show" ||
  { cat "$work/show"; fail "dfsm show does not give the camera and the scores"; }
"$dfsm" show "$work/out/broken" >"$work/show" && fail "dfsm show of a failed result exited 0"
grep -q "^error .*required field" "$work/show" || fail "dfsm show does not say why it failed"

# 2. --resume with everything complete redoes nothing.
stamp="$work/out/burst-1/result.json"
touch -d '2020-01-01' "$stamp"
"$dfsm" batch "$work/in" "$work/clip" --windows 5 --out "$work/out" --resume >"$work/log" 2>&1 || true
grep -q "8 complete already" "$work/log" || fail "--resume did not find the 8 complete results"
[ "$(stat -c %Y "$stamp")" = "$(date -d '2020-01-01' +%s)" ] || fail "--resume redid a burst"

# 3. kill -9 mid-run, then --resume: the rest is done, nothing finished is redone.
"$dfsm" batch "$work/in" --out "$work/killed" --jobs 1 >"$work/log" 2>&1 &
pid=$!
for _ in $(seq 600); do
  [ "$(ls "$work/killed"/*/summary.json 2>/dev/null | wc -l || true)" -ge 2 ] && break
  sleep 0.05
done
kill -9 "$pid" || true
wait "$pid" 2>/dev/null || true
finished=$(ls "$work/killed"/*/summary.json 2>/dev/null | wc -l || true)
[ "$finished" -ge 2 ] && [ "$finished" -lt 6 ] || fail "kill -9 came at $finished of 6 bursts"
for dir in "$work/killed"/*/; do
  [ -f "$dir/summary.json" ] || fail "$dir looks like a result but is not complete"
done
for file in "$work/killed"/*/result.json; do touch -d '2020-01-01' "$file"; done
"$dfsm" batch "$work/in" --out "$work/killed" --resume >"$work/log" 2>&1 || true
grep -q "$finished complete already" "$work/log" || fail "--resume did not skip the $finished finished"
[ "$(wc -l <"$work/killed/summary.jsonl")" -eq 6 ] || fail "the resumed batch does not list 6 bursts"
redone=$(find "$work/killed" -name result.json -newer "$work/in/burst-1/manifest.json" | wc -l)
[ "$redone" -eq $((6 - finished)) ] || fail "$redone bursts made after the kill, expected $((6 - finished))"

# 4. Three shards into one directory, merged: the same bursts, the same calibrations.
for shard in 0 1 2; do
  "$dfsm" batch "$work/in" --out "$work/sharded" --shard "$shard/3" >"$work/log" 2>&1 || true
  [ -s "$work/sharded/summary.shard-$shard-of-3.jsonl" ] || fail "shard $shard wrote no summary"
done
"$dfsm" batch --merge "$work/sharded" --out "$work/sharded" >"$work/log" 2>&1 && fail "merge hid a failed burst"
python3 - "$work/killed/summary.jsonl" "$work/sharded/summary.jsonl" <<'EOF' || fail "shards differ"
import json, sys
whole, merged = ({l["name"]: l for l in map(json.loads, open(f))} for f in sys.argv[1:3])
assert sorted(whole) == sorted(merged), (sorted(whole), sorted(merged))
for name, line in whole.items():
    assert line["status"] == merged[name]["status"], name
    if line["calibration"]:
        assert abs(line["calibration"]["f"] - merged[name]["calibration"]["f"]) < 1e-9, name
EOF

# 5. --calibrate-first: the bursts adjusted jointly, each burst's depth under
# that camera as a checked prior; a resumed run takes it from DIR/calibration.
"$dfsm" batch "$work/in" --out "$work/joint" --calibrate-first >"$work/log" 2>&1 || true
grep -q "joint calibration of 5 bursts" "$work/log" || fail "no joint calibration of the 5 bursts"
[ -s "$work/joint/calibration/joint.json" ] && [ -s "$work/joint/calibration/calibration.json" ] ||
  fail "DIR/calibration/ does not hold the joint calibration"
grep -Eq '"known": "(joint \(5 bursts|fused \([2-5] bursts; the joint calibration)' \
  "$work/joint/burst-2/result.json" || fail "burst-2 did not use the joint calibration's answer"
python3 - "$work/joint/calibration" <<'EOF' || fail "calibration.json does not hold the answer's f"
import json, sys
answer = json.load(open(sys.argv[1] + "/joint.json"))["answer"]
written = json.load(open(sys.argv[1] + "/calibration.json"))["camera_matrix"]["data"][0]
assert abs(answer["camera"]["fx"] - written) < 1e-9, (answer["camera"]["fx"], written)
EOF
"$dfsm" batch "$work/in" --out "$work/joint" --calibrate-first --resume >"$work/log" 2>&1 || true
grep -q "joint calibration of 5 bursts" "$work/log" || fail "the resumed run lost the joint calibration"

# 6. Usage errors name the problem.
"$dfsm" batch "$work/in" --out "$work/x" --shard 3/3 >"$work/log" 2>&1 && fail "--shard 3/3 accepted"
grep -q "I must be 0 to N-1" "$work/log" || fail "--shard 3/3 not explained"
"$dfsm" batch "$work/nothing" --out "$work/x" >"$work/log" 2>&1 && fail "a missing input accepted"
grep -q "no such file or directory" "$work/log" || fail "a missing input not named"
echo "PASS: 8 bursts (a tar, windows, a broken one), resume after kill -9, 3 shards merged, calibrated first"
