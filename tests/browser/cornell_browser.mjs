#!/usr/bin/env node
// Helper of cornell_browser_test.sh.
//
//   node cornell_browser.mjs points CORNELL.gltf OUTDIR
//     writes OUTDIR/points.csv (radbake --probe) and OUTDIR/points.json (tools/render_gltf.mjs --points):
//     one surface point on the red wall, the green wall, the floor, the back wall and the light.
//   node cornell_browser.mjs check --values values.csv --render render.json --ev EV --tolerance T
//                                  --label NAME [--control-ev EV2]
//     compares each rendered pixel (3×3 mean) with 255·sRGB_encode(clamp(2^EV·L, 0, 1)), L the exact
//     radiance from radbake --probe-out; fails on any channel further off than T code values. With
//     --control-ev the same pixels are also held against the values EV2 would give, which must
//     fail: a check that cannot tell EV from EV2 proves nothing.
//
// The points are read from the scene's geometry: each is the bilinear point (u, v) of a quad (the
// first four vertices of the named mesh, in file order), with u and v multiples of 1/8, so with
// --subdivide 8 it is a vertex of the baked mesh: the renderer's per-triangle interpolation of
// COLOR_0 and the solver's bilinear basis agree there exactly. The floor point is lit by the whole
// light (no block shadows it, nor its neighbouring patches); the others are in smooth regions too.

import fs from 'node:fs';
import path from 'node:path';

const POINTS = [
  // name, mesh, u, v: chosen so that the point is seen from the camera and away from shadow edges.
  { name: 'red_wall', mesh: 'red_wall', u: 4 / 8, v: 4 / 8 },
  { name: 'green_wall', mesh: 'green_wall', u: 4 / 8, v: 4 / 8 },
  // x ≈ 0.414, z ≈ 0.070: in front of the tall block, right of the short block's shadow.
  { name: 'floor', mesh: 'floor', u: 2 / 8, v: 1 / 8 },
  // Above the tall block (y ≈ 0.41), which hides the back wall's centre from the camera.
  { name: 'back_wall', mesh: 'back_wall', u: 4 / 8, v: 6 / 8 },
  { name: 'light', mesh: 'light', u: 4 / 8, v: 4 / 8 },
];

function fail(message) {
  process.stderr.write(`cornell_browser: ${message}\n`);
  process.exit(2);
}

function readGltf(file) {
  const g = JSON.parse(fs.readFileSync(file, 'utf8'));
  const buffers = g.buffers.map((b) => {
    if (b.uri.startsWith('data:')) return Buffer.from(b.uri.slice(b.uri.indexOf(',') + 1), 'base64');
    return fs.readFileSync(path.join(path.dirname(file), decodeURIComponent(b.uri)));
  });
  const accessor = (index) => {
    const a = g.accessors[index];
    const view = g.bufferViews[a.bufferView];
    const buf = buffers[view.buffer];
    const n = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4 }[a.type];
    const size = { 5126: 4, 5125: 4, 5123: 2, 5121: 1 }[a.componentType];
    const stride = view.byteStride || n * size;
    const base = (view.byteOffset || 0) + (a.byteOffset || 0);
    const out = [];
    for (let i = 0; i < a.count; ++i) {
      const row = [];
      for (let c = 0; c < n; ++c) {
        const o = base + i * stride + c * size;
        row.push(a.componentType === 5126 ? buf.readFloatLE(o) : a.componentType === 5125 ? buf.readUInt32LE(o)
          : a.componentType === 5123 ? buf.readUInt16LE(o) : buf.readUInt8(o));
      }
      out.push(n === 1 ? row[0] : row);
    }
    return out;
  };
  return { g, accessor };
}

const sub = (a, b) => a.map((x, i) => x - b[i]);
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const dot = (a, b) => a.reduce((s, x, i) => s + x * b[i], 0);
const normalize = (a) => { const l = Math.hypot(...a); return a.map((x) => x / l); };

function makePoints(gltfFile, outDir) {
  const { g, accessor } = readGltf(gltfFile);
  // The Cornell box has identity node transforms (its nodes carry no matrix/TRS but the camera's).
  for (const node of g.nodes) {
    if (node.mesh !== undefined && (node.matrix || node.translation || node.rotation || node.scale)) {
      fail(`node ${node.name} has a transform: this helper reads mesh-space positions as world space`);
    }
  }
  const rows = [];
  for (const p of POINTS) {
    const mesh = g.meshes.find((m) => m.name === p.mesh);
    if (!mesh) fail(`no mesh ${p.mesh} in ${gltfFile}`);
    const prim = mesh.primitives[0];
    const P = accessor(prim.attributes.POSITION);
    const N = accessor(prim.attributes.NORMAL);
    const [q0, q1, q2, q3] = P;
    const { u, v } = p;
    const w = [(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v];
    const position = [0, 1, 2].map((c) => w[0] * q0[c] + w[1] * q1[c] + w[2] * q2[c] + w[3] * q3[c]);
    // The side the surface faces: the file's vertex normal, checked against the quad's winding.
    const normal = normalize(N[0]);
    const faceNormal = normalize(cross(sub(q1, q0), sub(q3, q0)));
    if (Math.abs(dot(normal, faceNormal)) < 0.99) fail(`${p.mesh}: the first four vertices are no planar quad`);
    rows.push({ name: p.name, mesh: p.mesh, position, normal });
  }
  fs.mkdirSync(outDir, { recursive: true });
  fs.writeFileSync(path.join(outDir, 'points.csv'),
    'x,y,z,nx,ny,nz\n' + rows.map((r) => [...r.position, ...r.normal].map((x) => x.toPrecision(17)).join(',')).join('\n') + '\n');
  fs.writeFileSync(path.join(outDir, 'points.json'), JSON.stringify(rows, null, 1) + '\n');
}

const srgbEncode = (x) => (x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055);
const display = (L, ev) => 255 * srgbEncode(Math.min(Math.max(Math.pow(2, ev) * L, 0), 1));

function readValues(file) {
  const lines = fs.readFileSync(file, 'utf8').split('\n').map((l) => l.trim()).filter((l) => l.length);
  const rows = [];
  for (const [i, line] of lines.entries()) {
    if (i === 0 && /[a-z]/i.test(line)) continue; // header
    const v = line.split(',').map(Number);
    if (v.length !== 6 || v.some((x) => !Number.isFinite(x))) fail(`${file}: bad line ${line}`);
    rows.push({ position: v.slice(0, 3), L: v.slice(3, 6) });
  }
  return rows;
}

function check(args) {
  const opt = {};
  for (let i = 0; i < args.length; i += 2) opt[args[i].replace(/^--/, '')] = args[i + 1];
  for (const k of ['values', 'render', 'ev', 'tolerance', 'label']) if (opt[k] === undefined) fail(`check needs --${k}`);
  const ev = Number(opt.ev);
  const tolerance = Number(opt.tolerance);
  const values = readValues(opt.values);
  const render = JSON.parse(fs.readFileSync(opt.render, 'utf8'));
  if (values.length !== render.points.length) fail(`${values.length} probe values but ${render.points.length} rendered points`);

  let failures = 0;
  let worst = 0;
  let controlWorst = 0;
  const controlEv = opt['control-ev'] !== undefined ? Number(opt['control-ev']) : null;
  const fmt = (a, d = 1) => '(' + a.map((x) => x.toFixed(d).padStart(5)).join(' ') + ')';
  process.stdout.write(`${opt.label}: EV ${ev}, tolerance ±${tolerance} code values (3×3 mean vs 255·sRGB(clamp(2^EV·L)))\n`);
  for (const [i, pt] of render.points.entries()) {
    const val = values[i];
    if (Math.hypot(...sub(val.position, pt.world)) > 1e-6) fail(`point ${pt.name}: the probe and the render disagree on where it is`);
    const problems = [];
    if (!pt.inView) problems.push('outside the view');
    if (!pt.visible) problems.push(`hidden behind ${pt.firstHitObject}`);
    let errors = [NaN, NaN, NaN];
    const expected = val.L.map((L) => display(L, ev));
    if (pt.rgba) {
      errors = [0, 1, 2].map((c) => pt.rgba[c] - expected[c]);
      const off = Math.max(...errors.map(Math.abs));
      worst = Math.max(worst, off);
      if (off > tolerance) problems.push(`off by ${off.toFixed(2)} > ${tolerance}`);
      if (controlEv !== null) {
        const wrong = val.L.map((L) => display(L, controlEv));
        controlWorst = Math.max(controlWorst, ...[0, 1, 2].map((c) => Math.abs(pt.rgba[c] - wrong[c])));
      }
    }
    if (problems.length) ++failures;
    process.stdout.write(`  ${pt.name.padEnd(11)} L ${fmt(val.L, 4)}  expected ${fmt(expected)}  got ${pt.rgba ? fmt(pt.rgba.slice(0, 3)) : '(none)'}` +
      `  error ${fmt(errors, 2)}  at pixel (${pt.pixel.map((x) => x.toFixed(1)).join(', ')})` +
      `  ${problems.length ? 'FAIL: ' + problems.join('; ') : 'ok'}\n`);
  }
  process.stdout.write(`${opt.label}: largest error ${worst.toFixed(2)} code values\n`);
  if (controlEv !== null) {
    const caught = controlWorst > tolerance;
    process.stdout.write(`${opt.label}: control: against EV ${controlEv} the same pixels are off by up to ${controlWorst.toFixed(2)}` +
      ` code values: ${caught ? 'the check tells the two apart' : 'FAIL: the check cannot tell the two apart'}\n`);
    if (!caught) ++failures;
  }
  if (failures) {
    process.stdout.write(`${opt.label}: FAIL (${failures} problem${failures > 1 ? 's' : ''})\n`);
    process.exit(1);
  }
  process.stdout.write(`${opt.label}: ok\n`);
}

const [command, ...rest] = process.argv.slice(2);
if (command === 'points' && rest.length === 2) makePoints(rest[0], rest[1]);
else if (command === 'check') check(rest);
else fail('usage: cornell_browser.mjs points CORNELL.gltf OUTDIR | check --values V --render R --ev EV --tolerance T --label NAME [--control-ev EV2]');
