#!/usr/bin/env node
// Renders a glTF/GLB with three.js in headless Chromium (Debian's /usr/bin/chromium, driven by
// playwright-core; WebGL through SwiftShader) and reads pixels back.
//
//   node tools/render_gltf.mjs IN.glb OUT.png [--points points.json] [--width 512] [--height 512]
//                              [--exposure EV] [--chromium PATH] [--timeout SECONDS]
//
// The view is the glTF's first camera (its aspect ratio is replaced by width/height); a file with
// no camera is framed by its bounds. The scene has no lights and no environment and a black
// background, so what shows is what the file carries: unlit colours, emission and lightmaps
// (MOZ_lightmap, through a small GLTFLoader plugin below). Output is sRGB (outputColorSpace =
// SRGBColorSpace). Without --exposure there is no tone mapping (NoToneMapping: values clip at 1);
// with --exposure EV, LinearToneMapping with toneMappingExposure = 2^EV (clip(2^EV · colour)).
//
// points.json: an array of points, each [x, y, z] or {"name": ..., "position": [x, y, z]} in world
// space. For each, the page projects the point with the same camera (Vector3.project) and reports
// its pixel (x right, y down, from the top-left corner of OUT.png), the RGBA there (the 3×3 window
// mean and the centre pixel), whether it is inside the view and whether it is the first surface
// seen along its ray (a Raycaster against the scene).
//
// Prints one JSON object on stdout: {"width", "height", "png", "camera", "renderer", "points": [...]}.
// Exit codes: 0 ok, 1 usage, 2 the page failed (load, WebGL, ...), 77 Chromium or the npm
// packages (tools/node_modules/three, playwright-core) are missing.

import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const toolsDir = path.dirname(fileURLToPath(import.meta.url));
const threeDir = path.join(toolsDir, 'node_modules', 'three');

function usage(message) {
  if (message) process.stderr.write(`render_gltf: ${message}\n`);
  process.stderr.write('usage: node tools/render_gltf.mjs IN.glb OUT.png [--points points.json] ' +
    '[--width 512] [--height 512] [--exposure EV] [--chromium PATH] [--timeout SECONDS]\n');
  process.exit(1);
}

function parseArgs(argv) {
  const opts = { width: 512, height: 512, exposure: null, points: null, timeout: 120,
    chromium: process.env.CHROMIUM || '/usr/bin/chromium' };
  const positional = [];
  for (let i = 0; i < argv.length; ++i) {
    const a = argv[i];
    const value = () => { if (i + 1 >= argv.length) usage(`${a} needs a value`); return argv[++i]; };
    if (a === '--points') opts.points = value();
    else if (a === '--width') opts.width = Number(value());
    else if (a === '--height') opts.height = Number(value());
    else if (a === '--exposure') opts.exposure = Number(value());
    else if (a === '--chromium') opts.chromium = value();
    else if (a === '--timeout') opts.timeout = Number(value());
    else if (a === '-h' || a === '--help') usage();
    else if (a.startsWith('--')) usage(`unknown option ${a}`);
    else positional.push(a);
  }
  if (positional.length !== 2) usage('needs IN and OUT');
  [opts.input, opts.output] = positional;
  for (const k of ['width', 'height']) {
    if (!Number.isInteger(opts[k]) || opts[k] < 1 || opts[k] > 8192) usage(`bad --${k}`);
  }
  if (opts.exposure !== null && !Number.isFinite(opts.exposure)) usage('bad --exposure');
  return opts;
}

// A PNG (8-bit RGBA, no interlace) from top-down rows, with node's zlib only.
const crcTable = (() => {
  const t = new Uint32Array(256);
  for (let n = 0; n < 256; ++n) {
    let c = n;
    for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    t[n] = c >>> 0;
  }
  return t;
})();
function crc32(buf) {
  let c = 0xffffffff;
  for (const b of buf) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}
function pngChunk(type, data) {
  const len = Buffer.alloc(4);
  len.writeUInt32BE(data.length);
  const body = Buffer.concat([Buffer.from(type, 'ascii'), data]);
  const crc = Buffer.alloc(4);
  crc.writeUInt32BE(crc32(body));
  return Buffer.concat([len, body, crc]);
}
function encodePng(width, height, rgba) {
  const raw = Buffer.alloc((width * 4 + 1) * height);
  for (let y = 0; y < height; ++y) {
    raw[y * (width * 4 + 1)] = 0; // filter: none
    rgba.copy(raw, y * (width * 4 + 1) + 1, y * width * 4, (y + 1) * width * 4);
  }
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0);
  ihdr.writeUInt32BE(height, 4);
  ihdr[8] = 8; // bit depth
  ihdr[9] = 6; // RGBA
  ihdr[10] = ihdr[11] = ihdr[12] = 0;
  // sRGB chunk (rendering intent: perceptual): the pixels are sRGB-encoded.
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
    pngChunk('IHDR', ihdr), pngChunk('sRGB', Buffer.from([0])),
    pngChunk('IDAT', zlib.deflateSync(raw, { level: 6 })), pngChunk('IEND', Buffer.alloc(0))]);
}

const PAGE = `<!doctype html>
<html><head><meta charset="utf-8"><title>radbake render</title>
<style>html,body{margin:0;background:#000}</style>
<script type="importmap">
{ "imports": { "three": "/three/build/three.module.js", "three/addons/": "/three/examples/jsm/" } }
</script>
<script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

// MOZ_lightmap: {index, texCoord, intensity} on a material. The texture holds sRGB-encoded
// irradiance / intensity; three's lightMap term adds lightMap · lightMapIntensity to the
// irradiance (so the surface shows baseColor/π · E for a diffuse material).
class MozLightmapPlugin {
  constructor(parser) { this.parser = parser; this.name = 'MOZ_lightmap'; }
  extendMaterialParams(materialIndex, materialParams) {
    const def = this.parser.json.materials[materialIndex];
    const ext = def.extensions && def.extensions.MOZ_lightmap;
    if (!ext) return Promise.resolve();
    materialParams.lightMapIntensity = ext.intensity !== undefined ? ext.intensity : 1;
    return this.parser.assignTexture(materialParams, 'lightMap',
      { index: ext.index, texCoord: ext.texCoord !== undefined ? ext.texCoord : 0 },
      THREE.SRGBColorSpace);
  }
}

window.renderGltf = async function (opts) {
  const { width, height, exposure, points } = opts;
  const canvas = document.createElement('canvas');
  canvas.width = width; canvas.height = height;
  document.body.appendChild(canvas);
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: false,
    preserveDrawingBuffer: true, powerPreference: 'high-performance' });
  renderer.setPixelRatio(1);
  renderer.setSize(width, height, false);
  renderer.outputColorSpace = THREE.SRGBColorSpace;
  if (exposure === null) {
    renderer.toneMapping = THREE.NoToneMapping;
  } else {
    renderer.toneMapping = THREE.LinearToneMapping;
    renderer.toneMappingExposure = Math.pow(2, exposure);
  }
  renderer.setClearColor(0x000000, 1);

  const loader = new GLTFLoader();
  loader.register((parser) => new MozLightmapPlugin(parser));
  const gltf = await loader.loadAsync('/model');
  const scene = gltf.scene;
  scene.background = null;
  scene.updateMatrixWorld(true);

  let camera;
  let cameraSource;
  if (gltf.cameras && gltf.cameras.length > 0) {
    camera = gltf.cameras[0];
    cameraSource = 'gltf';
    if (camera.isPerspectiveCamera) camera.aspect = width / height;
    camera.updateProjectionMatrix();
    camera.updateMatrixWorld(true);
  } else {
    const box = new THREE.Box3().setFromObject(scene);
    const centre = box.getCenter(new THREE.Vector3());
    const radius = Math.max(box.getSize(new THREE.Vector3()).length() / 2, 1e-6);
    camera = new THREE.PerspectiveCamera(45, width / height, radius / 100, radius * 100);
    const distance = radius / Math.sin(THREE.MathUtils.degToRad(45 / 2));
    camera.position.copy(centre).add(new THREE.Vector3(0, 0, distance));
    camera.lookAt(centre);
    camera.updateProjectionMatrix();
    camera.updateMatrixWorld(true);
    cameraSource = 'bounds';
  }

  renderer.render(scene, camera);
  const gl = renderer.getContext();
  const pixels = new Uint8Array(width * height * 4);
  gl.readPixels(0, 0, width, height, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
  const glError = gl.getError();
  // Flip to top-down rows.
  const rows = new Uint8Array(width * height * 4);
  for (let y = 0; y < height; ++y) {
    rows.set(pixels.subarray((height - 1 - y) * width * 4, (height - y) * width * 4), y * width * 4);
  }
  const at = (x, y) => rows.subarray((y * width + x) * 4, (y * width + x) * 4 + 4);

  const raycaster = new THREE.Raycaster();
  const cameraPosition = new THREE.Vector3().setFromMatrixPosition(camera.matrixWorld);
  const results = (points || []).map((entry, i) => {
    const p = Array.isArray(entry) ? entry : entry.position;
    const name = Array.isArray(entry) ? String(i) : (entry.name !== undefined ? entry.name : String(i));
    const world = new THREE.Vector3(p[0], p[1], p[2]);
    const ndc = world.clone().project(camera);
    const fx = (ndc.x + 1) / 2 * width;   // continuous pixel coordinates, top-left origin
    const fy = (1 - ndc.y) / 2 * height;
    const px = Math.floor(fx), py = Math.floor(fy);
    const inView = ndc.z > -1 && ndc.z < 1 && px >= 1 && py >= 1 && px < width - 1 && py < height - 1;
    let rgba = null, centre = null, spread = null;
    if (inView) {
      const sum = [0, 0, 0, 0], lo = [255, 255, 255, 255], hi = [0, 0, 0, 0];
      for (let dy = -1; dy <= 1; ++dy) for (let dx = -1; dx <= 1; ++dx) {
        const v = at(px + dx, py + dy);
        for (let c = 0; c < 4; ++c) { sum[c] += v[c]; lo[c] = Math.min(lo[c], v[c]); hi[c] = Math.max(hi[c], v[c]); }
      }
      rgba = sum.map((s) => s / 9);
      centre = Array.from(at(px, py));
      spread = hi.map((h, c) => h - lo[c]);
    }
    // Is the point the first surface along the camera ray through it?
    const toPoint = world.clone().sub(cameraPosition);
    const distance = toPoint.length();
    raycaster.set(cameraPosition, toPoint.normalize());
    raycaster.near = 0; raycaster.far = distance * 1.01 + 1e-6;
    const hits = raycaster.intersectObject(scene, true);
    const firstHit = hits.length ? hits[0].distance : Infinity;
    const visible = firstHit >= distance - Math.max(1e-4, 1e-3 * distance);
    return { name, world: p, ndc: [ndc.x, ndc.y, ndc.z], pixel: [fx, fy], inView, visible,
      firstHitDistance: Number.isFinite(firstHit) ? firstHit : null, distance,
      firstHitObject: hits.length ? hits[0].object.name : null, rgba, centre, spread };
  });

  // Base64 of the top-down RGBA rows, in chunks (String.fromCharCode has an argument limit).
  let binary = '';
  for (let i = 0; i < rows.length; i += 0x8000) binary += String.fromCharCode.apply(null, rows.subarray(i, i + 0x8000));
  const info = renderer.info.render;
  const debugInfo = gl.getExtension('WEBGL_debug_renderer_info');
  return {
    rgbaBase64: btoa(binary),
    glError,
    camera: { source: cameraSource, type: camera.type, position: cameraPosition.toArray(),
      quaternion: camera.getWorldQuaternion(new THREE.Quaternion()).toArray(),
      fov: camera.fov, aspect: camera.aspect, near: camera.near, far: camera.far },
    renderer: { three: THREE.REVISION, webgl2: renderer.capabilities.isWebGL2 !== false,
      gpu: debugInfo ? gl.getParameter(debugInfo.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER),
      toneMapping: exposure === null ? 'None' : 'Linear', toneMappingExposure: renderer.toneMappingExposure,
      outputColorSpace: renderer.outputColorSpace, triangles: info.triangles, calls: info.calls },
    points: results,
  };
};
window.renderReady = true;
</script></head><body></body></html>`;

const MIME = { '.js': 'text/javascript', '.mjs': 'text/javascript', '.json': 'application/json',
  '.html': 'text/html', '.glb': 'model/gltf-binary', '.gltf': 'model/gltf+json', '.png': 'image/png',
  '.jpg': 'image/jpeg', '.jpeg': 'image/jpeg', '.bin': 'application/octet-stream', '.wasm': 'application/wasm' };

function serve(inputPath) {
  const inputDir = path.dirname(path.resolve(inputPath));
  const send = (res, file) => {
    fs.readFile(file, (err, data) => {
      if (err) { res.writeHead(404); res.end('not found'); return; }
      res.writeHead(200, { 'Content-Type': MIME[path.extname(file).toLowerCase()] || 'application/octet-stream',
        'Cache-Control': 'no-store' });
      res.end(data);
    });
  };
  // Only what lies under a root: no '..' escapes.
  const under = (root, rel) => {
    const file = path.resolve(root, '.' + path.posix.normalize('/' + rel));
    return file.startsWith(root + path.sep) || file === root ? file : null;
  };
  const server = http.createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://localhost').pathname);
    let file = null;
    if (url === '/' || url === '/index.html') {
      res.writeHead(200, { 'Content-Type': 'text/html', 'Cache-Control': 'no-store' });
      res.end(PAGE);
      return;
    }
    if (url === '/favicon.ico') { res.writeHead(204); res.end(); return; }
    if (url === '/model') file = path.resolve(inputPath);
    else if (url.startsWith('/three/')) file = under(threeDir, url.slice('/three/'.length));
    // A .gltf's relative URIs (buffers, images) resolve against /model's folder, i.e. '/'.
    else file = under(inputDir, url.slice(1));
    if (!file) { res.writeHead(404); res.end('not found'); return; }
    send(res, file);
  });
  return new Promise((resolve, reject) => {
    server.once('error', reject);
    server.listen(0, '127.0.0.1', () => resolve(server));
  });
}

async function main() {
  const opts = parseArgs(process.argv.slice(2));
  if (!fs.existsSync(opts.input)) { process.stderr.write(`render_gltf: no such file ${opts.input}\n`); process.exit(1); }
  let points = null;
  if (opts.points) points = JSON.parse(fs.readFileSync(opts.points, 'utf8'));

  if (!fs.existsSync(path.join(threeDir, 'build', 'three.module.js'))) {
    process.stderr.write('render_gltf: SKIP: tools/node_modules/three is missing (scripts/setup.sh)\n');
    process.exit(77);
  }
  let chromium;
  try {
    const require = createRequire(import.meta.url);
    ({ chromium } = require('playwright-core'));
  } catch (e) {
    process.stderr.write('render_gltf: SKIP: tools/node_modules/playwright-core is missing (scripts/setup.sh)\n');
    process.exit(77);
  }
  if (!fs.existsSync(opts.chromium)) {
    process.stderr.write(`render_gltf: SKIP: no Chromium at ${opts.chromium} (apt-get install chromium)\n`);
    process.exit(77);
  }

  const server = await serve(opts.input);
  const port = server.address().port;
  let browser = null;
  const consoleLines = [];
  const timer = setTimeout(() => {
    process.stderr.write(`render_gltf: timed out after ${opts.timeout} s\n${consoleLines.join('\n')}\n`);
    process.exit(2);
  }, opts.timeout * 1000);
  try {
    browser = await chromium.launch({
      executablePath: opts.chromium,
      headless: true,
      // No GPU here: WebGL through SwiftShader (software), which Chromium only allows for WebGL
      // when told it is fine (--enable-unsafe-swiftshader).
      args: ['--use-angle=swiftshader', '--use-gl=angle', '--enable-unsafe-swiftshader',
        '--ignore-gpu-blocklist', '--no-sandbox', '--disable-dev-shm-usage',
        '--force-color-profile=srgb'],
    });
    const page = await browser.newPage({ viewport: { width: opts.width, height: opts.height }, deviceScaleFactor: 1 });
    page.on('console', (m) => consoleLines.push(`console.${m.type()}: ${m.text()}`));
    page.on('pageerror', (e) => consoleLines.push(`pageerror: ${e.message}`));
    await page.goto(`http://127.0.0.1:${port}/`, { waitUntil: 'load' });
    await page.waitForFunction(() => window.renderReady === true, null, { timeout: opts.timeout * 1000 });
    const result = await page.evaluate((o) => window.renderGltf(o),
      { width: opts.width, height: opts.height, exposure: opts.exposure, points });
    const rgba = Buffer.from(result.rgbaBase64, 'base64');
    if (rgba.length !== opts.width * opts.height * 4) throw new Error('pixel read-back has the wrong size');
    fs.writeFileSync(opts.output, encodePng(opts.width, opts.height, rgba));
    // A black frame means WebGL drew nothing: say so rather than report black pixels.
    let lit = 0;
    for (let i = 0; i < rgba.length; i += 4) if (rgba[i] | rgba[i + 1] | rgba[i + 2]) ++lit;
    const out = { input: opts.input, width: opts.width, height: opts.height, png: opts.output,
      exposure: opts.exposure, litPixelFraction: lit / (opts.width * opts.height),
      glError: result.glError, camera: result.camera, renderer: result.renderer, points: result.points,
      console: consoleLines };
    process.stdout.write(JSON.stringify(out, null, 1) + '\n');
    if (lit === 0) { process.stderr.write('render_gltf: the frame is black\n'); process.exitCode = 2; }
  } catch (e) {
    process.stderr.write(`render_gltf: ${e.message}\n${consoleLines.join('\n')}\n`);
    process.exitCode = 2;
  } finally {
    clearTimeout(timer);
    if (browser) await browser.close();
    server.close();
  }
}

main();
