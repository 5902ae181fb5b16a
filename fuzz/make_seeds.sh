#!/usr/bin/env bash
# Regenerates the fuzz seeds from the project's own generated data (never ../shared/data):
# the generated CMU-style BVH fixtures cut to 2 frames, a small synthetic H3.6M exp-map text
# (sine waves, written by awk) and its BVH made by `motion-cli convert`.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$here/.."
bvh="$here/seeds/bvh_parse"
txt="$here/seeds/h36m_text_parse"
mkdir -p "$bvh" "$txt"

# CMU-style fixtures (CRLF/tabs and odd spacing), cut to their first 2 frames.
for name in cmu_style_crlf_tabs cmu_style_odd_spacing; do
  awk 'BEGIN { frames = -1 }
       /^Frames:/ { sub(/[0-9]+/, "2") }
       { print }
       /^Frame Time:/ { frames = 0; next }
       frames >= 0 && NF > 0 { if (++frames >= 2) exit }' \
    "$repo/tests/fixtures/bvh/$name.bvh" > "$bvh/$name.bvh"
done

# Synthetic exp-map text: H3.6M (99 columns, 4 frames), CMU width (117), and an odd width.
synth() { # columns frames
  awk -v cols="$1" -v frames="$2" 'BEGIN {
    for (t = 0; t < frames; t++) {
      line = ""
      for (d = 0; d < cols; d++) {
        v = (d < 3) ? 10 * sin(t + d) : 0.5 * sin(0.3 * t + d)
        line = line (d ? "," : "") sprintf("%.9g", v)
      }
      print line
    }
  }'
}
synth 99 4 > "$txt/h36m_4_frames.txt"
synth 117 2 > "$txt/cmu_2_frames.txt"
synth 5 3 > "$txt/five_columns.txt"

# A BVH on the H3.6M skeleton, written by our converter.
cargo run --quiet --manifest-path "$repo/Cargo.toml" -p motion-cli -- \
  convert "$txt/h36m_4_frames.txt" "$bvh/h36m_4_frames.bvh"
ls -l "$bvh" "$txt"
