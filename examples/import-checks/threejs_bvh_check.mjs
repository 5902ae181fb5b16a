import { readFileSync } from 'node:fs';
import { BVHLoader } from 'three/examples/jsm/loaders/BVHLoader.js';
const text = readFileSync(process.argv[2], 'utf8');
const result = new BVHLoader().parse(text);
const bones = result.skeleton.bones;
const clip = result.clip;
const frames = clip.tracks[0].times.length;
// how far the root moves and how much a knee rotates over the clip
const pos = clip.tracks.find(t => t.name.endsWith('.position'));
const p = pos.values; const n = p.length / 3;
const dx = p[3*(n-1)] - p[0], dz = p[3*(n-1)+2] - p[2];
const knee = clip.tracks.find(t => t.name.startsWith('RightLeg.quaternion'));
let minW = 1, maxW = -1; for (let i = 0; i < knee.values.length; i += 4) { minW = Math.min(minW, knee.values[i+3]); maxW = Math.max(maxW, knee.values[i+3]); }
console.log(`three.js BVHLoader: ${bones.length} bones, ${frames} frames, duration ${clip.duration.toFixed(2)} s, root moved ${Math.hypot(dx, dz).toFixed(0)} mm in the floor plane, RightLeg quaternion w range ${minW.toFixed(3)}..${maxW.toFixed(3)}`);
