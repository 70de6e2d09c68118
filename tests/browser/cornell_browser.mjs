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
const area = (a, b, c) => Math.hypot(...cross(sub(b, a), sub(c, a))) / 2;
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

// Refined edges of a baked file (vertex colours, --view Standard): where a cell meets one split
// once more, the coarse side is a fan from the finer side's midpoint m, so the written mesh has no
// hanging vertex. Per primitive: (1) no triangle edge has a vertex of that primitive at its
// midpoint (a T-junction: the renderer would show a crack along it); (2) the refined edges a–m–b
// (m the midpoint of a and b, both its neighbours, no triangle edge a–b, and triangles of unequal
// size on either side of a–m and m–b: not a grid line) are listed, and the
// midpoints of a–m and m–b, in smooth light (every vertex of the triangles on either side within
// `smooth` code values of the point's expected colour) and at least `margin` (scene units) from
// every other mesh are written as points to render, each with the colour the file gives it:
// COLOR_0 interpolated along the edge, as both sides' triangles do.
function makeEdgePoints(gltfFile, outDir, smooth, margin) {
  const { g, accessor } = readGltf(gltfFile);
  for (const node of g.nodes) {
    if (node.mesh !== undefined && (node.matrix || node.translation || node.rotation || node.scale)) {
      fail(`node ${node.name} has a transform: this helper reads mesh-space positions as world space`);
    }
  }
  const rows = [];
  let junctions = 0, refined = 0, nearOther = 0;
  const firstJunction = [];
  // Every triangle edge of each mesh, to keep the points clear of the other meshes: a point on the
  // floor at a block's foot shares its pixel with the block's face, whatever the depth test says.
  const segmentsOf = g.meshes.map((mesh) => mesh.primitives.flatMap((prim) => {
    if (prim.indices === undefined) return [];
    const P = accessor(prim.attributes.POSITION), I = accessor(prim.indices);
    const out = [];
    for (let t = 0; t + 2 < I.length; t += 3) for (let e = 0; e < 3; ++e) out.push([P[I[t + e]], P[I[t + (e + 1) % 3]]]);
    return out;
  }));
  const clearance = (x, self) => {
    let best = Infinity;
    segmentsOf.forEach((segs, k) => {
      if (k === self) return;
      for (const [a, b] of segs) {
        const ab = sub(b, a), t = Math.min(1, Math.max(0, dot(sub(x, a), ab) / Math.max(dot(ab, ab), 1e-30)));
        best = Math.min(best, Math.hypot(...sub(x, a.map((v, c) => v + t * ab[c]))));
      }
    });
    return best;
  };
  for (const [meshIndex, mesh] of g.meshes.entries()) {
    for (const [pi, prim] of mesh.primitives.entries()) {
      if (prim.indices === undefined || prim.attributes.COLOR_0 === undefined) continue;
      const P = accessor(prim.attributes.POSITION), C = accessor(prim.attributes.COLOR_0), I = accessor(prim.indices);
      const size = Math.max(...[0, 1, 2].map((c) => Math.max(...P.map((p) => Math.abs(p[c])))), 1e-30);
      const key = (p) => p.map((x) => Math.round(x / size * 1e6)).join(',');
      const at = new Map();  // position → a vertex there (seams may hold several with the same position)
      P.forEach((p, i) => { if (!at.has(key(p))) at.set(key(p), i); });
      const vkey = (i) => key(P[i]);
      const edges = new Map();  // "ka|kb" (sorted) → third vertices of the triangles on it
      const neighbours = new Map();  // position key → vertex indices joined to it by an edge
      for (let t = 0; t + 2 < I.length; t += 3) {
        const tri = [I[t], I[t + 1], I[t + 2]];
        for (let e = 0; e < 3; ++e) {
          const a = tri[e], b = tri[(e + 1) % 3], c = tri[(e + 2) % 3];
          const ek = [vkey(a), vkey(b)].sort().join('|');
          if (!edges.has(ek)) edges.set(ek, []);
          edges.get(ek).push(c);
          for (const [x, y] of [[a, b], [b, a]]) {
            if (!neighbours.has(vkey(x))) neighbours.set(vkey(x), new Set());
            neighbours.get(vkey(x)).add(y);
          }
          const mid = P[a].map((x, k) => (x + P[b][k]) / 2);
          if (at.has(key(mid))) {
            ++junctions;
            if (firstJunction.length === 0) firstJunction.push(`${mesh.name}: triangle ${t / 3} edge ${a}-${b} passes through vertex ${at.get(key(mid))}`);
          }
        }
      }
      const colourAt = (i) => C[i].slice(0, 3);
      const shown = (c) => c.map((x) => display(x, 0));
      for (const [mk, nb] of neighbours) {
        const m = at.get(mk);
        const list = [...nb];
        for (let x = 0; x < list.length; ++x) for (let y = x + 1; y < list.length; ++y) {
          const a = list[x], b = list[y];
          if (key(P[a].map((v, k) => (v + P[b][k]) / 2)) !== mk) continue;
          if (edges.has([vkey(a), vkey(b)].sort().join('|'))) continue;
          // A grid line through m also has a–m–b; a refined edge has cells of two sizes on its two
          // sides: the fan's triangle on a–m is at least twice the finer side's.
          const sides = (end) => edges.get([vkey(end), mk].sort().join('|')).map((c) => area(P[end], P[m], P[c]));
          const unequal = (x) => x.length === 2 && Math.max(...x) >= 1.5 * Math.min(...x);
          if (!unequal(sides(a)) || !unequal(sides(b))) continue;
          ++refined;
          for (const end of [a, b]) {
            const ek = [vkey(end), mk].sort().join('|');
            const position = P[end].map((v, k) => (v + P[m][k]) / 2);
            const colour = colourAt(end).map((v, k) => (v + colourAt(m)[k]) / 2);
            const expected = shown(colour);
            const around = [end, m, ...edges.get(ek)].map((i) => shown(colourAt(i)));
            const spread = Math.max(...around.map((c) => Math.max(...c.map((v, k) => Math.abs(v - expected[k])))));
            if (spread > smooth) continue;
            if (clearance(position, meshIndex) < margin) { ++nearOther; continue; }
            rows.push({ name: `${mesh.name}.${pi}:${end}-${m}`, position, colour, expected });
          }
        }
      }
    }
  }
  process.stdout.write(`edges: ${refined} refined edges (a fan beside a split cell), ${junctions} T-junctions, ` +
    `${rows.length} points in smooth light (${nearOther} more within ${margin} of another mesh left out)\n`);
  if (junctions) fail(`T-junction: ${firstJunction[0]}`);
  if (refined === 0) fail(`${gltfFile} has no refined edge: nothing to check`);
  fs.mkdirSync(outDir, { recursive: true });
  fs.writeFileSync(path.join(outDir, 'edges.json'), JSON.stringify(rows, null, 1) + '\n');
}

// The control of the T-junction count: a copy of a baked file in which the first fan found (the
// coarse side of a refined edge a–m–b, triangles around m larger than the finer side's) is
// re-triangulated without m, as a mesh that leaves hanging vertices would be (m still a corner of
// the finer side's triangles); `edges` must then
// fail. Written as .gltf with its buffer embedded.
function makeCrack(gltfFile, outFile) {
  const { g, accessor } = readGltf(gltfFile);
  for (const mesh of g.meshes) {
    for (const prim of mesh.primitives) {
      if (prim.indices === undefined) continue;
      const P = accessor(prim.attributes.POSITION), I = accessor(prim.indices);
      const tris = [];
      for (let t = 0; t + 2 < I.length; t += 3) tris.push([I[t], I[t + 1], I[t + 2]]);
      for (let m = 0; m < P.length; ++m) {
        const around = tris.map((t, k) => [t, k]).filter(([t]) => t.includes(m));
        const big = around.filter(([t]) => area(P[t[0]], P[t[1]], P[t[2]]) > 1.5 * Math.min(...around.map(([u]) => area(P[u[0]], P[u[1]], P[u[2]]))));
        if (big.length !== 3) continue;  // a fan from a midpoint of one edge: 3 triangles
        // ... with the finer side in this primitive too: at a primitive's border (balance across
        // primitives that meet there) m would be left in no triangle, and no T-junction to find.
        if (around.length === big.length) continue;
        const corners = [...new Set(big.flatMap(([t]) => t))].filter((v) => v !== m);
        if (corners.length !== 4) continue;
        // The fan in winding order: m, x, y for each triangle; chain the corners from the one after m.
        const next = new Map(big.map(([t]) => { const i = t.indexOf(m); return [t[(i + 1) % 3], t[(i + 2) % 3]]; }));
        const start = corners.find((c) => ![...next.values()].includes(c));
        const ring = [start];
        while (next.has(ring[ring.length - 1])) ring.push(next.get(ring[ring.length - 1]));
        if (ring.length !== 4) continue;
        // m is the midpoint of the ring's ends (the coarse cell's edge it splits), or this is no such fan.
        const mid = P[ring[0]].map((x, k) => (x + P[ring[3]][k]) / 2);
        if (Math.hypot(...mid.map((x, k) => x - P[m][k])) > 1e-6 * Math.hypot(...sub(P[ring[0]], P[ring[3]]))) continue;
        const keep = tris.filter((_, k) => !big.some(([, j]) => j === k));
        keep.push([ring[0], ring[1], ring[2]], [ring[0], ring[2], ring[3]]);
        // Replace the primitive's indices with a new accessor in a new buffer.
        const data = Buffer.alloc(keep.length * 12);
        keep.flat().forEach((v, i) => data.writeUInt32LE(v, i * 4));
        g.buffers.push({ byteLength: data.length, uri: 'data:application/octet-stream;base64,' + data.toString('base64') });
        g.bufferViews.push({ buffer: g.buffers.length - 1, byteLength: data.length, target: 34963 });
        g.accessors.push({ bufferView: g.bufferViews.length - 1, componentType: 5125, count: keep.length * 3, type: 'SCALAR' });
        prim.indices = g.accessors.length - 1;
        for (const b of g.buffers) {
          if (!b.uri.startsWith('data:')) {
            b.uri = 'data:application/octet-stream;base64,' + fs.readFileSync(path.join(path.dirname(gltfFile), decodeURIComponent(b.uri))).toString('base64');
          }
        }
        fs.writeFileSync(outFile, JSON.stringify(g));
        process.stdout.write(`crack: ${mesh.name}: the fan around vertex ${m} re-triangulated without it\n`);
        return;
      }
    }
  }
  fail(`${gltfFile}: no fan found to crack`);
}

// The rendered refined-edge points: the pixel holding each point (where a crack along the edge
// would let the black background through) within `tolerance` code values of the file's colour
// there; at least `min` points in view and not hidden. Each expected colour is at least `dark`
// code values above black in some channel, or a crack could pass unseen (checked).
function checkEdges(args) {
  const opt = {};
  for (let i = 0; i < args.length; i += 2) opt[args[i].replace(/^--/, '')] = args[i + 1];
  for (const k of ['points', 'render', 'tolerance', 'dark', 'min', 'label']) if (opt[k] === undefined) fail(`check-edges needs --${k}`);
  const points = JSON.parse(fs.readFileSync(opt.points, 'utf8'));
  const render = JSON.parse(fs.readFileSync(opt.render, 'utf8'));
  if (points.length !== render.points.length) fail(`${points.length} points but ${render.points.length} rendered`);
  const tolerance = Number(opt.tolerance), dark = Number(opt.dark), min = Number(opt.min);
  let seen = 0, failures = 0, worst = 0;
  for (const [i, pt] of render.points.entries()) {
    if (!pt.inView || !pt.visible || !pt.centre) continue;  // behind a block, or outside the view
    ++seen;
    const expected = points[i].expected;
    const off = Math.max(...[0, 1, 2].map((c) => Math.abs(pt.centre[c] - expected[c])));
    const tooDark = Math.max(...expected) < dark;
    worst = Math.max(worst, off);
    if (off > tolerance || tooDark) {
      ++failures;
      process.stdout.write(`  ${pt.name} at pixel (${pt.pixel.map((x) => x.toFixed(1)).join(', ')}): expected (${expected.map((x) => x.toFixed(1)).join(' ')}),` +
        ` got (${pt.centre.slice(0, 3).join(' ')}): FAIL${tooDark ? ' (too dark to show a crack)' : ''}\n`);
    }
  }
  process.stdout.write(`${opt.label}: ${seen} of ${points.length} refined-edge points in view; largest error ${worst.toFixed(2)} code values ` +
    `(tolerance ±${tolerance})\n`);
  if (seen < min) { process.stdout.write(`${opt.label}: FAIL (fewer than ${min} points in view)\n`); process.exit(1); }
  if (failures) { process.stdout.write(`${opt.label}: FAIL (${failures} point${failures > 1 ? 's' : ''})\n`); process.exit(1); }
  process.stdout.write(`${opt.label}: ok\n`);
}

const [command, ...rest] = process.argv.slice(2);
if (command === 'points' && rest.length === 2) makePoints(rest[0], rest[1]);
else if (command === 'check') check(rest);
else if (command === 'edges' && rest.length === 4) makeEdgePoints(rest[0], rest[1], Number(rest[2]), Number(rest[3]));
else if (command === 'check-edges') checkEdges(rest);
else if (command === 'crack' && rest.length === 2) makeCrack(rest[0], rest[1]);
else fail('usage: cornell_browser.mjs points CORNELL.gltf OUTDIR | check --values V --render R --ev EV --tolerance T --label NAME [--control-ev EV2]' +
  ' | edges BAKED.gltf OUTDIR SMOOTH MARGIN | check-edges --points P --render R --tolerance T --dark D --min N --label NAME | crack BAKED.gltf OUT.gltf');
