// Renders an SVG cut file to a PNG preview in headless Chromium (Debian's chromium, driven by
// playwright-core from client/web/node_modules), scaled to fit WIDTH pixels on white.
//   node scripts/svg_to_png.mjs FILE.svg OUT.png [WIDTH]
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const { chromium } = await import(path.join(repo, 'client/web/node_modules/playwright-core/index.mjs'));
const [svgPath, pngPath, widthArg] = process.argv.slice(2);
const svg = fs.readFileSync(svgPath, 'utf8').replace(/<\?xml[^>]*>/, '');
const [, w, h] = svg.match(/viewBox="0 0 ([\d.]+) ([\d.]+)"/);
const width = Number(widthArg || 1200), height = Math.ceil((width * Number(h)) / Number(w));
// Hairline cut strokes are invisible at preview scale: drawn 0.3 mm wide here (the file keeps them thin).
const shown = svg.replace(/width="[^"]*mm" height="[^"]*mm"/, `width="${width}" height="${height}"`).replaceAll('stroke-width="0.01"', 'stroke-width="0.3"');
const browser = await chromium.launch({ executablePath: process.env.KGD_CHROMIUM || '/usr/bin/chromium',
  args: ['--headless=new', '--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update'] });
const page = await browser.newPage({ viewport: { width, height } });
await page.setContent(`<html><body style="margin:0;background:#fff">${shown}</body></html>`);
await page.screenshot({ path: pngPath, timeout: 60000 });
await browser.close();
