#!/usr/bin/env bash
# Regenerates the sample stills and clips in renders/ from a run of the default scenario:
# `lander run scenarios/default.yaml --video`, then ffmpeg cuts stills and short clips.
set -euo pipefail
cd "$(dirname "$0")/.."
scenario="${1:-scenarios/default.yaml}"
out="out/renders_$(basename "$scenario" .yaml)"
./build/lander run "$scenario" --out "$out" --video --quiet || true  # a failed landing still renders
mkdir -p renders
for t in 10 19 ; do
  ffmpeg -loglevel error -y -ss "$t" -i "$out/camera.mp4" -frames:v 1 "renders/camera_t${t}s.png"
  ffmpeg -loglevel error -y -ss "$t" -i "$out/chase.mp4" -frames:v 1 "renders/chase_t${t}s.png"
done
ffmpeg -loglevel error -y -ss 12 -t 10 -i "$out/camera.mp4" -c copy renders/camera_clip.mp4
ffmpeg -loglevel error -y -ss 12 -t 10 -i "$out/chase.mp4" -c copy renders/chase_clip.mp4
echo "renders/ updated from $out"
