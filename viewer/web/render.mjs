// Renders a recorded run, served by the viewer in log mode, to an MP4 (ffmpeg, H.264) and optionally
// to still PNGs, in headless Chromium with software WebGL. Each video frame is one frame of the run
// sought on the robot clock (not a screen capture in real time), so a slow machine makes the same
// video, only later.
//
//   node render.mjs --url http://127.0.0.1:PORT/ --out run.mp4 [--label TEXT] [--fps 30]
//                   [--size 640x480] [--from T] [--to T] [--stills T1,T2,... --stills-out PREFIX]
import { spawn } from 'node:child_process';
import { chromium } from 'playwright-core';
import { launchOptions } from './chromium.mjs';

function parse(argv) {
  const o = { fps: 30, size: '854x480', label: '', from: null, to: null, stills: [], stillsOut: null, out: null, url: null };
  for (let i = 2; i < argv.length; ++i) {
    const a = argv[i], v = () => { if (i + 1 >= argv.length) throw new Error(`${a} needs a value`); return argv[++i]; };
    if (a === '--url') o.url = v();
    else if (a === '--out') o.out = v();
    else if (a === '--label') o.label = v();
    else if (a === '--fps') o.fps = Number(v());
    else if (a === '--size') o.size = v();
    else if (a === '--from') o.from = Number(v());
    else if (a === '--to') o.to = Number(v());
    else if (a === '--stills') o.stills = v().split(',').filter((s) => s).map(Number);
    else if (a === '--stills-out') o.stillsOut = v();
    else throw new Error(`unknown option ${a}`);
  }
  if (!o.url) throw new Error('--url is required');
  if (!(o.fps > 0 && o.fps <= 120)) throw new Error(`--fps ${o.fps} is not in (0, 120]`);
  if (!/^\d+x\d+$/.test(o.size)) throw new Error(`--size ${o.size} is not WIDTHxHEIGHT`);
  if (o.stills.some((t) => !Number.isFinite(t))) throw new Error('--stills takes numbers');
  return o;
}

async function main() {
  const o = parse(process.argv);
  const [w, h] = o.size.split('x').map(Number);
  const browser = await chromium.launch(launchOptions());
  const page = await browser.newPage({ viewport: { width: w, height: h } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  const q = new URLSearchParams({ render: '1', width: String(w), height: String(h) });
  if (o.label) q.set('label', o.label);
  page.setDefaultTimeout(120000);  // a loaded machine may take more than the default 30 s to load the page
  await page.goto(`${o.url}?${q}`);
  await page.evaluate(() => window.hpr.ready);
  if (errors.length) throw new Error(`the page reported: ${errors.join('; ')}`);
  const s = await page.evaluate(() => window.hpr.summary);
  if (!s) throw new Error('the viewer is not in log mode');
  const from = o.from ?? s.t0, to = Math.min(o.to ?? s.t0 + s.duration, s.t0 + s.duration);
  const t0 = Date.now();
  if (o.out) {
    const n = Math.max(1, Math.floor((to - from) * o.fps + 1e-9) + 1);
    const ff = spawn('ffmpeg', ['-loglevel', 'error', '-y', '-f', 'image2pipe', '-framerate', String(o.fps), '-c:v', 'mjpeg', '-i', '-',
      '-c:v', 'libx264', '-preset', 'veryfast', '-crf', '23', '-pix_fmt', 'yuv420p', '-movflags', '+faststart', o.out],
    { stdio: ['pipe', 'inherit', 'inherit'] });
    const done = new Promise((resolve, reject) => ff.on('close', (c) => (c === 0 ? resolve() : reject(new Error(`ffmpeg exited with ${c}`)))));
    for (let k = 0; k < n; ++k) {
      await page.evaluate((t) => window.hpr.seek(t), from + k / o.fps);
      const jpg = await page.screenshot({ type: 'jpeg', quality: 90 });
      if (!ff.stdin.write(jpg)) await new Promise((r) => ff.stdin.once('drain', r));
      if (process.stderr.isTTY && (k % 30 === 0 || k === n - 1)) process.stderr.write(`\rrender: ${o.out}: frame ${k + 1}/${n}`);
    }
    ff.stdin.end();
    await done;
    process.stderr.write(`\rrender: ${o.out}: ${n} frames (${(to - from).toFixed(2)} s at ${o.fps} fps) in ${((Date.now() - t0) / 1000).toFixed(1)} s\n`);
  }
  for (let k = 0; k < o.stills.length; ++k) {
    await page.evaluate((t) => window.hpr.seek(t), o.stills[k]);
    await page.screenshot({ path: `${o.stillsOut ?? 'still'}-${k}.png` });
  }
  if (errors.length) throw new Error(`the page reported: ${errors.join('; ')}`);
  await browser.close();
}

main().catch((e) => { process.stderr.write(`render: ${e.message}\n`); process.exit(1); });
