// Drives the viewer's page in headless Chromium for the browser test: loads it, seeks two moments
// of a recorded run, and prints one JSON object with what a person would check by eye, measured:
// console errors, the joint angles read back from the scene graph, and pixel counts of the robot,
// the push arrow, the capture point and the planned step in the rendered WebGL image.
//
//   node browser_check.mjs URL T_PUSH T_BEFORE
import { chromium } from 'playwright-core';
import { launchOptions } from '../chromium.mjs';

const [url, tPush, tBefore] = [process.argv[2], Number(process.argv[3]), Number(process.argv[4])];
const W = 640, H = 480;

/// In the page: counts pixels of the WebGL image in a box by colour class.
function pixelStats({ box, side }) {
  const gl = document.querySelector('#view canvas');
  const c = document.createElement('canvas');
  c.width = gl.width; c.height = gl.height;
  const ctx = c.getContext('2d');
  ctx.drawImage(gl, 0, 0);
  const img = ctx.getImageData(0, 0, c.width, c.height).data;
  const robotLike = (r, g, b) => b >= r - 4 && Math.abs(r - g) < 28 && (r + g + b) / 3 < 215;
  const red = (r, g, b) => r > 150 && g < 100 && b < 100;
  const teal = (r, g, b) => r < 90 && g > 110 && b > 110 && Math.abs(g - b) < 40;  // the capture point and step
  const count = (x0, y0, x1, y1) => {
    const out = { pixels: 0, robot: 0, red: 0, teal: 0 };
    for (let y = Math.max(0, Math.floor(y0)); y < Math.min(c.height, Math.ceil(y1)); ++y) {
      for (let x = Math.max(0, Math.floor(x0)); x < Math.min(c.width, Math.ceil(x1)); ++x) {
        const i = 4 * (y * c.width + x);
        ++out.pixels;
        if (robotLike(img[i], img[i + 1], img[i + 2])) ++out.robot;
        if (red(img[i], img[i + 1], img[i + 2])) ++out.red;
        if (teal(img[i], img[i + 1], img[i + 2])) ++out.teal;
      }
    }
    return out;
  };
  const result = { whole: count(0, 0, c.width, c.height) };
  if (box) result.box = count(box.x0, box.y0, box.x1, box.y1);
  if (side) result.side = count(side.x0, side.y0, side.x1, side.y1);
  return result;
}

async function moment(page, t) {
  const at = await page.evaluate((tt) => window.hpr.seek(tt), t);
  const angles = await page.evaluate(() => window.hpr.jointAngles());
  const robot = await page.evaluate(() => window.hpr.screenBox('robot'));
  const push = await page.evaluate(() => window.hpr.screenBox('push'));
  // A box of the robot's size beside it, to the left (the plot panel is on the right).
  const w = robot ? robot.x1 - robot.x0 : 0;
  const side = robot ? { x0: robot.x0 - 1.6 * w, y0: robot.y0, x1: robot.x0 - 0.6 * w, y1: robot.y1 } : null;
  const pixels = await page.evaluate(pixelStats, { box: robot, side });
  const pushPixels = push ? (await page.evaluate(pixelStats, { box: push, side: null })).box : null;
  const stepping = await page.evaluate(() => window.hpr.steppingVisible());
  const stepBox = await page.evaluate(() => window.hpr.screenBox('step'));
  const captureBox = await page.evaluate(() => window.hpr.screenBox('capture'));
  const boxPixels = async (box) => (box ? (await page.evaluate(pixelStats, { box, side: null })).box : null);
  return {
    ...at, angles, robot_box: robot, push_box: push, pixels, push_pixels: pushPixels, push_visible: await page.evaluate(() => window.hpr.pushVisible()),
    stepping, step_box: stepBox, step_pixels: await boxPixels(stepBox), capture_box: captureBox, capture_pixels: await boxPixels(captureBox),
  };
}

const browser = await chromium.launch(launchOptions());
const errors = [];
try {
  const page = await browser.newPage({ viewport: { width: W, height: H } });
  page.on('console', (m) => { if (m.type() === 'error' || m.type() === 'warning') errors.push(`${m.type()}: ${m.text()}`); });
  page.on('pageerror', (e) => errors.push(`pageerror: ${e.message}`));
  page.on('requestfailed', (r) => errors.push(`request failed: ${r.url()}`));
  page.on('response', (r) => { if (r.status() >= 400) errors.push(`HTTP ${r.status()}: ${r.url()}`); });
  // A loaded machine (the other tests, the builds beside them) may take well over Playwright's 30 s
  // default to load the page's scripts and meshes.
  page.setDefaultTimeout(120000);
  await page.goto(`${url}?render=1&width=${W}&height=${H}`);
  await page.evaluate(() => window.hpr.ready);
  const info = await page.evaluate(() => ({ mode: window.hpr.mode, robot: window.hpr.info.name }));
  const push = await moment(page, tPush);
  const before = await moment(page, tBefore);
  process.stdout.write(JSON.stringify({ errors, info, push, before }) + '\n');
} catch (e) {
  process.stdout.write(JSON.stringify({ errors: errors.concat([`driver: ${e.message}`]) }) + '\n');
} finally {
  await browser.close();
}
