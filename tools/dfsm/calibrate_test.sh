#!/bin/sh
# dfsm calibrate over bursts of one camera, one burst of another camera of the
# same size and a burst that cannot be read: the joint calibration keeps the
# camera's bursts, leaves the other camera's out as disagreeing and names the
# unreadable one; the fusion runs on the same bursts; no usable burst is exit
# 1 with the reason; a burst.tar reads as its directory; a folder of images
# is cut into windows; a burst whose exposure drifts gets the focal length
# that 'dfsm process' gives it (the same sparse stage). Usage:
# calibrate_test.sh DFSM WORKDIR
set -eu
dfsm="$1" work="$2"
rm -rf "$work" && mkdir -p "$work"
synth() { "$dfsm" synth --width 320 --height 240 --rotation 2 --supersampling 1 "$@" >/dev/null; }
for seed in 1 2 3; do synth --out "$work/camera-$seed" --seed "$seed"; done
synth --out "$work/other" --seed 9 --f 250 --k1 -0.12
fail() { echo "FAIL: $1"; cat "$work/log"; exit 1; }
"$dfsm" calibrate "$work"/camera-* "$work/other" "$work/missing" --out "$work/joint" >"$work/log" 2>&1 ||
  fail "the joint calibration exited $?"
joint="$work/joint/joint.json"
for file in calibration.json calibration.yaml joint.json; do
  [ -s "$work/joint/$file" ] || fail "no $file"
done
[ "$(grep -c '"outcome": "joined"' "$joint")" -eq 3 ] || fail "the camera's 3 bursts did not all join"
[ "$(grep -c '"outcome": "disagrees"' "$joint")" -eq 1 ] || fail "the other camera was not left out"
grep -q '"outcome": "failed"' "$joint" || fail "the unreadable burst is not listed"
grep -q "missing: not a directory" "$joint" || fail "the unreadable burst's reason is missing"
grep -q "1 of 4 bursts disagree" "$work/log" || fail "the disagreement is not said"
# The joint focal length within 5 % of the camera's 352 px (1.1 x 320).
f=$(sed -n 's/^joint *f \([0-9.]*\) px.*/\1/p' "$work/log")
awk -v f="$f" 'BEGIN { exit !(f > 334.4 && f < 369.6) }' || fail "joint f $f px, not within 5 % of 352"
# The answer: the joint camera or the fusion of the same bursts, said, and
# the camera calibration.json holds.
grep -Eq '^answer +(joint|fused): f [0-9.]+ px' "$work/log" || fail "no answer said"
answer=$(python3 -c 'import json,sys; print("%.6f" % json.load(open(sys.argv[1]))["answer"]["camera"]["fx"])' "$joint")
written=$(python3 -c 'import json,sys; print("%.6f" % json.load(open(sys.argv[1]))["camera_matrix"]["data"][0])' "$work/joint/calibration.json")
[ "$answer" = "$written" ] || fail "calibration.json's f $written px is not the answer's $answer px"
# One burst as dfsmd serves it (a tar of its directory) reads as the directory.
tar -C "$work" -cf "$work/camera-3.tar" camera-3
"$dfsm" calibrate "$work/camera-1" "$work/camera-2" "$work/camera-3.tar" --method fusion \
  --out "$work/fused" >"$work/log" 2>&1 || fail "the fusion exited $?"
[ -s "$work/fused/fusion.json" ] || fail "no fusion.json"
grep -q "camera-3.tar: f " "$work/log" || fail "the tar was not read"
# A clip's frames (a folder of images) cut into windows, each one burst.
"$dfsm" calibrate "$work/camera-1/frames" --windows 5 --out "$work/windows" >"$work/log" 2>&1 ||
  fail "the windows of a folder exited $?"
for window in "[0, 5)" "[5, 10)"; do
  grep -qF "frames $window" "$work/windows/joint.json" || fail "no window $window"
done
if "$dfsm" calibrate "$work/camera-1/frames" --windows 20 --out "$work/none" >"$work/log" 2>&1; then
  fail "a window longer than the clip was read"
fi
grep -q "fewer than one window of 20" "$work/log" || fail "the short clip is not named"
# Each burst's own calibration is its sparse stage as 'dfsm process' runs it:
# exposure compensated (f 340.22 instead of 347.42 px here without it).
synth --out "$work/drift" --seed 4 --exposure-drift 0.1
"$dfsm" process "$work/drift" --no-dense --out "$work/drift-process" >/dev/null 2>&1 ||
  fail "dfsm process of the drifting burst exited $?"
processed=$(tr -d ' \n' <"$work/drift-process/calibration.json" |
  sed -n 's/.*"camera_matrix":{"cols":3,"data":\[\([0-9.e+-]*\),.*/\1/p')
"$dfsm" calibrate "$work/drift" "$work/camera-1" --out "$work/drift-joint" >"$work/log" 2>&1 ||
  fail "the calibration with the drifting burst exited $?"
own=$(sed -n 's/^.*drift: f \([0-9.]*\) px.*/\1/p' "$work/log")
[ -n "$processed" ] && [ "$(printf '%.2f' "$processed")" = "$own" ] ||
  fail "the drifting burst's own f $own px is not dfsm process's $processed px"
if "$dfsm" calibrate "$work/missing" --out "$work/none" >"$work/log" 2>&1; then
  fail "no usable burst gave a calibration"
fi
grep -q "no burst could be read and reconstructed" "$work/log" || fail "no reason given"
echo "PASS: joint calibration f $f px from 3 bursts, the other camera left out, the unreadable named"
rm -rf "$work"
