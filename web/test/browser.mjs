// The page in a real headless Chromium (Debian's /usr/bin/chromium, or $CHROMIUM): it must load
// the wasm module and three.js, generate 200 finite poses live, draw the skinned mannequin with
// its bones moving, switch action, play the shipped motion-matching database steered by the
// keyboard (on the same mannequin), and draw the stick figure when asked. With the shared assets
// beside the repository (../shared/assets/characters) it also loads the female mannequin through
// ?character= and checks it the same way (another body, unchanged code); without them it says so.
// Prints the per-step cost of the model in the browser. Usage: node test/browser.mjs [screenshot.png]
import { createServer } from "node:http";
import { access, readFile, writeFile } from "node:fs/promises";
import { extname, join, normalize, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";
import { PNG } from "pngjs";

const root = resolve(fileURLToPath(import.meta.url), "../..");
const shot = process.argv[2] ?? join(root, "..", "target", "web-screenshot.png");
const types = { ".html": "text/html", ".js": "text/javascript", ".mjs": "text/javascript", ".wasm": "application/wasm", ".json": "application/json" };

function check(ok, what) {
  if (!ok) {
    console.error(`FAILED: ${what}`);
    process.exitCode = 1;
    throw new Error(what);
  }
  console.log(`ok: ${what}`);
}

const characters = join(root, "..", "..", "shared", "assets", "characters");
const female = "quaternius_mannequin_female.glb";
const haveFemale = await access(join(characters, female)).then(() => true, () => false);
const server = createServer(async (req, res) => {
  const path = normalize(decodeURIComponent(new URL(req.url, "http://x").pathname)).replace(/^(\.\.[/\\])+/, "");
  const file = path.startsWith("/characters/")
    ? join(characters, path.slice("/characters/".length))
    : join(root, path.endsWith("/") ? `${path}index.html` : path);
  try {
    const body = await readFile(file);
    res.writeHead(200, { "content-type": types[extname(file)] ?? "application/octet-stream" });
    res.end(body);
  } catch {
    res.writeHead(404);
    res.end();
  }
});
await new Promise((r) => server.listen(0, "127.0.0.1", r));
const url = `http://127.0.0.1:${server.address().port}/index.html?seed=1`;

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  args: [
    "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
    "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync",
  ],
});
try {
  const page = await browser.newPage({ viewport: { width: 960, height: 600 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  page.on("console", (m) => m.type() === "error" && errors.push(m.text()));
  await page.goto(url);
  await page.waitForFunction(() => window.motionStatus?.error || window.motionStatus?.poses >= 200, null, { timeout: 90_000 });
  let status = await page.evaluate(() => window.motionStatus);
  check(!status.error, `page runs without error (${status.error ?? "none"})`);
  check(status.poses >= 200, `${status.poses} poses generated live`);
  check(status.finite, "every joint position finite");

  // The skinned mannequin: drawn, its bones moving between frames, its feet near the floor.
  check(status.skinned, "the mannequin's skeleton is attached to the character");
  const bones0 = (await page.evaluate(() => window.motionDebug())).bones;
  await page.waitForTimeout(500);
  const bones1 = (await page.evaluate(() => window.motionDebug())).bones;
  const handMoved = Math.hypot(...bones1.hand_l.map((v, i) => v - bones0.hand_l[i]));
  check(handMoved > 0.05, `the mannequin's hand moved ${handMoved.toFixed(2)} m in 0.5 s`);
  // The balls of the feet (joints a few cm over the sole): the lower one near the floor.
  const feet = Math.min(bones1.ball_l[1], bones1.ball_r[1]);
  check(feet > -0.05 && feet < 0.12 && bones1.head[1] > 1.3,
    `the lower ball of the foot at ${feet.toFixed(2)} m, the head at ${bones1.head[1].toFixed(2)} m`);
  const meshPixels = await page.evaluate(() => window.motionMeshPixels());
  check(meshPixels > 2000, `the skinned mesh covers ${meshPixels} pixels`);
  await page.screenshot({ path: shot.replace(/\.png$/, "-skinned.png") });

  await page.selectOption("#action", "sitting");
  const before = status.poses;
  await page.waitForFunction((n) => window.motionStatus.error || window.motionStatus.poses >= n, before + 50, { timeout: 60_000 });
  status = await page.evaluate(() => window.motionStatus);
  check(!status.error && status.action === "sitting" && status.finite, `action switched to ${status.action}, ${status.poses - before} more finite poses`);

  // The shipped motion-matching database: its own rig, steered by the keyboard.
  await page.selectOption("#source", "matching");
  const switched = (await page.evaluate(() => window.motionStatus)).poses;
  await page.waitForFunction((n) => window.motionStatus.error || window.motionStatus.poses >= n, switched + 30, { timeout: 60_000 });
  const from = await page.evaluate(() => window.motionDebug());
  await page.keyboard.down("ArrowUp");
  await page.waitForTimeout(2000);
  await page.keyboard.up("ArrowUp");
  const to = await page.evaluate(() => window.motionDebug());
  status = await page.evaluate(() => window.motionStatus);
  const moved = Math.hypot(to.root[0] - from.root[0], to.root[2] - from.root[2]);
  check(!status.error && status.source === "matching" && status.finite && from.joints > 15 && from.joints !== 32,
    `motion matching plays on its ${from.joints}-joint CMU rig (${status.error ?? "no error"})`);
  check(moved > 0.5, `steered by the keyboard, the database's character walked ${moved.toFixed(2)} m in 2 s`);
  check(status.skinned, "the mannequin follows the database's CMU rig too");

  const us = await page.evaluate(() => window.motionBench(500));
  check(Number.isFinite(us) && us > 0, `one model step in the browser: ${us.toFixed(1)} µs (500 steps, wasm32, one thread)`);

  await page.check("#sticks"); // the debug stick figure instead of the mesh
  await page.waitForTimeout(200);
  const png = await page.screenshot({ path: shot });
  const img = PNG.sync.read(png);
  const [r0, g0, b0] = img.data; // the top-left corner: background
  let differing = 0, bone = 0;
  for (let i = 0; i < img.data.length; i += 4) {
    const [r, g, b] = [img.data[i], img.data[i + 1], img.data[i + 2]];
    if (Math.abs(r - r0) + Math.abs(g - g0) + Math.abs(b - b0) > 30) differing++;
    if (r > 150 && g > 80 && g < 220 && b < 120 && r > b + 80) bone++; // the orange bones, lit
  }
  const pixels = img.width * img.height;
  check(differing > pixels * 0.01, `screenshot ${shot} not blank: ${(100 * differing / pixels).toFixed(1)}% of pixels differ from the background`);
  check(bone > 200, `the skeleton is drawn: ${bone} bone-coloured pixels`);
  check(errors.length === 0, `no console errors${errors.length ? `: ${errors.join(" | ")}` : ""}`);

  // Another body through ?character=: the female mannequin (its own proportions and rest pose).
  if (haveFemale) {
    const other = await browser.newPage({ viewport: { width: 960, height: 600 } });
    other.on("pageerror", (e) => errors.push(String(e)));
    await other.goto(`${url}&character=/characters/${female}`);
    await other.waitForFunction(() => window.motionStatus?.error || window.motionStatus?.poses >= 100, null, { timeout: 90_000 });
    const st = await other.evaluate(() => window.motionStatus);
    check(!st.error && st.skinned, `the female mannequin (${st.character} nodes) is driven (${st.error ?? "no error"})`);
    const a = (await other.evaluate(() => window.motionDebug())).bones;
    await other.waitForTimeout(500);
    const b = (await other.evaluate(() => window.motionDebug())).bones;
    const hand = Math.hypot(...b.hand_l.map((v, i) => v - a.hand_l[i]));
    const low = Math.min(b.ball_l[1], b.ball_r[1]);
    check(hand > 0.05 && low > -0.05 && low < 0.12 && b.head[1] > 1.3,
      `female: hand moved ${hand.toFixed(2)} m in 0.5 s, lower ball of the foot at ${low.toFixed(2)} m, head at ${b.head[1].toFixed(2)} m`);
    const px = await other.evaluate(() => window.motionMeshPixels());
    check(px > 2000, `the female mesh covers ${px} pixels`);
    await other.screenshot({ path: shot.replace(/\.png$/, "-female.png") });
    check(errors.length === 0, `no console errors${errors.length ? `: ${errors.join(" | ")}` : ""}`);
  } else {
    console.log(`skipped: the female mannequin (no ${join(characters, female)})`);
  }
} finally {
  await browser.close();
  server.close();
}
