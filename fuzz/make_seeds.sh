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

# .npy: the exp-map texts converted by our writer (float64, C order), and a float32 one.
npy="$here/seeds/npy_parse"
mkdir -p "$npy"
for name in h36m_4_frames cmu_2_frames; do
  cargo run --quiet --manifest-path "$repo/Cargo.toml" -p motion-cli -- \
    convert "$txt/$name.txt" "$npy/$name.npy"
done
cargo run --quiet --manifest-path "$repo/Cargo.toml" -p motion-cli -- \
  convert "$txt/h36m_4_frames.txt" "$npy/h36m_4_frames_positions.npy" --positions

# Weights: the parity fixtures (tiny random-weight models of every architecture, made by
# training/export_fixtures.py) as whole files, and for the structure-aware target their config
# JSON after a selector byte (0 vgru-d, 1 gru-d, 2 dae-lstm, 3 vgru-d f16: weights_config.rs).
weights="$here/seeds/weights_load"
config="$here/seeds/weights_config"
mkdir -p "$weights" "$config"
i=0
for name in vgru_d gru_d dae_lstm vgru_d_f16; do
  cp "$repo/tests/fixtures/parity/$name.safetensors" "$weights/"
  python3 - "$repo/tests/fixtures/parity/$name.safetensors" "$config/$name.bin" "$i" <<'PY'
import json, struct, sys
with open(sys.argv[1], "rb") as f:
    n = struct.unpack("<Q", f.read(8))[0]
    header = json.loads(f.read(n))
with open(sys.argv[2], "wb") as out:
    out.write(bytes([int(sys.argv[3])]) + header["__metadata__"]["config"].encode())
PY
  i=$((i + 1))
done

# BVH seeds for the retargeting loader: the H3.6M one and the CMU-style rig walk of
# examples/make_rig_seed.rs, cut to 4 frames.
retarget="$here/seeds/bvh_retarget"
mkdir -p "$retarget"
cp "$bvh/h36m_4_frames.bvh" "$retarget/"
cargo run --quiet --manifest-path "$repo/Cargo.toml" --example make_rig_seed >/dev/null
awk 'BEGIN { frames = -1 }
     /^Frames:/ { sub(/[0-9]+/, "4") }
     { print }
     /^Frame Time:/ { frames = 0; next }
     frames >= 0 && NF > 0 { if (++frames >= 4) exit }' \
  "$repo/examples/cmu_rig_walk.bvh" > "$retarget/cmu_rig_4_frames.bvh"

# Joint maps: a full map for the CMU-style demo rig and a partial one.
maps="$here/seeds/joint_map"
mkdir -p "$maps"
cat > "$maps/cmu.json" <<'JSON'
{"Hips": "Hips", "LeftUpLeg": "LeftUpLeg", "LeftLeg": "LeftLeg", "LeftFoot": "LeftFoot", "LeftToeBase": "LeftToeBase",
 "RightUpLeg": "RightUpLeg", "RightLeg": "RightLeg", "RightFoot": "RightFoot", "RightToeBase": "RightToeBase",
 "Spine": "Spine", "Spine1": "Spine1", "Neck": "Neck", "Head": "Head",
 "LeftShoulder": "LeftShoulder", "LeftArm": "LeftArm", "LeftForeArm": "LeftForeArm", "LeftHand": "LeftHand",
 "RightShoulder": "RightShoulder", "RightArm": "RightArm", "RightForeArm": "RightForeArm", "RightHand": "RightHand"}
JSON
echo '{"Hips": "Hips", "Head": "Head"}' > "$maps/partial.json"
ls -l "$bvh" "$txt" "$npy" "$weights" "$config" "$retarget" "$maps"
