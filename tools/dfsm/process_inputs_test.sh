#!/bin/sh
# dfsm process on a folder of images and on a glob of them gives the result it
# gives on the burst directory of the same frames: the same calibration.json
# and depth.tiff, byte for byte. Usage: process_inputs_test.sh DFSM WORKDIR
set -eu
dfsm="$1" work="$2"
rm -rf "$work" && mkdir -p "$work"
"$dfsm" synth --out "$work/burst" --width 320 --height 240 --frames 8 --supersampling 1 >/dev/null
"$dfsm" process "$work/burst" --out "$work/from-burst" --planes 32 >/dev/null 2>&1
"$dfsm" process "$work/burst/frames" --out "$work/from-folder" --planes 32 >/dev/null 2>&1
"$dfsm" process "$work/burst/frames/*.png" --out "$work/from-glob" --planes 32 >/dev/null 2>&1
for result in from-folder from-glob; do
  for file in calibration.json depth.tiff; do
    cmp "$work/from-burst/$file" "$work/$result/$file" ||
      { echo "FAIL: $result/$file differs from the burst directory's"; exit 1; }
  done
done
# A video that is not one, a file that is no video and a folder without images
# are each named.
touch "$work/clip.mp4" "$work/notes.txt"
if "$dfsm" process "$work/clip.mp4" --out "$work/none" 2>"$work/err"; then echo "FAIL: an empty video was read"; exit 1; fi
grep -q "cannot be opened as a video\|video module" "$work/err" || { echo "FAIL: $(cat "$work/err")"; exit 1; }
if "$dfsm" process "$work/notes.txt" --out "$work/none" 2>"$work/err"; then echo "FAIL: a text file was read"; exit 1; fi
grep -q "is a file but not a video" "$work/err" || { echo "FAIL: $(cat "$work/err")"; exit 1; }
mkdir -p "$work/empty"
if "$dfsm" process "$work/empty" --out "$work/none" 2>"$work/err"; then echo "FAIL: an empty folder was read"; exit 1; fi
grep -q "names no PNG or JPEG images" "$work/err" || { echo "FAIL: $(cat "$work/err")"; exit 1; }
echo "PASS: folder and glob give the burst's calibration.json and depth.tiff; a broken video, a text file and an empty folder are named"
rm -rf "$work"
