// The page of `hgraph view` (core/render/view_render.h writes the data it reads): the scene,
// the paths and the robot in three.js, a legend, the animation controls and the chart of the
// post-optimization. Runs as a classic script after three (the global THREE), from file://.
// window.hgraphView is the page's contract with its browser test (tests/view): `ready` once
// the first frame is drawn, `error` if building the scene failed, and the helpers below.
(function () {
  'use strict';
  const api = { ready: false, error: null, webgl: false };
  window.hgraphView = api;

  function decode(base64, Type) {
    const bytes = Uint8Array.from(atob(base64), (c) => c.charCodeAt(0));
    return new Type(bytes.buffer, 0, bytes.byteLength / Type.BYTES_PER_ELEMENT);
  }

  function format(v) {
    if (v === null || v === undefined || Number.isNaN(v)) return '\u2013';
    if (v === Infinity) return 'inf';
    if (v === -Infinity) return '-inf';
    return String(Number(v.toPrecision(5)));
  }

  function element(tag, attrs, text) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    if (text !== undefined) e.textContent = text;
    return e;
  }

  function build(data) {
    const canvas = document.getElementById('view');
    const play = document.getElementById('play');
    const slider = document.getElementById('time');
    const speedSelect = document.getElementById('speed');
    const renderer = new THREE.WebGLRenderer({ canvas, antialias: true });
    api.webgl = renderer.getContext() !== null;
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    const scene = new THREE.Scene();
    scene.background = new THREE.Color(0xf4f4f2);
    scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8a80, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(0.4, -0.6, 1.0);
    scene.add(sun);

    const lo = new THREE.Vector3(...data.bounds.lower);
    const hi = new THREE.Vector3(...data.bounds.upper);
    const centre = lo.clone().add(hi).multiplyScalar(0.5);
    const size = Math.max(hi.clone().sub(lo).length(), 1e-6);

    // Meshes are shared by obstacles and bodies that use the same file.
    const geometries = data.meshes.map((m) => {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(decode(m.positions, Float32Array), 3));
      g.setIndex(new THREE.BufferAttribute(decode(m.indices, Uint32Array), 1));
      g.computeVertexNormals();
      return g;
    });
    function shapeGeometry(shape) {
      switch (shape.type) {
        case 'box': return new THREE.BoxGeometry(...shape.size);
        case 'sphere': return new THREE.SphereGeometry(Math.max(shape.radius, size * 0.002), 32, 16);
        case 'cylinder': {
          // three's cylinders stand along Y, hgraph's along Z.
          const g = new THREE.CylinderGeometry(shape.radius, shape.radius, shape.length, 40);
          g.rotateX(Math.PI / 2);
          return g;
        }
        case 'mesh': return geometries[shape.mesh];
      }
      throw new Error('unknown shape ' + shape.type);
    }

    const obstacleMaterial = new THREE.MeshStandardMaterial({
      color: 0x8d8d8d, roughness: 0.85, metalness: 0.0, side: THREE.DoubleSide,
    });
    const obstacles = new THREE.Group();
    for (const o of data.obstacles) {
      const mesh = new THREE.Mesh(shapeGeometry(o.shape), obstacleMaterial);
      mesh.matrixAutoUpdate = false;
      mesh.matrix.fromArray(o.pose);
      obstacles.add(mesh);
    }
    scene.add(obstacles);

    const box = new THREE.Box3(lo, hi);
    const bounds = new THREE.Box3Helper(box, 0xb0b0b0);
    scene.add(bounds);

    // Paths: one tube of instanced cylinders per trace, so that width is in world units and the
    // merged path can be thick (WebGL draws lines one pixel wide). Unlit, so that a path's
    // pixels have its colour exactly.
    const unit = new THREE.CylinderGeometry(1, 1, 1, 10, 1, true);
    unit.rotateX(Math.PI / 2);
    const joint = new THREE.SphereGeometry(1, 10, 6);
    const Z = new THREE.Vector3(0, 0, 1);
    function tube(points, colours, radius) {
      const group = new THREE.Group();
      const n = points.length;
      if (n === 0) return group;
      const material = new THREE.MeshBasicMaterial({ color: 0xffffff });
      const segments = new THREE.InstancedMesh(unit, material, Math.max(n - 1, 1));
      const joints = new THREE.InstancedMesh(joint, material, n);
      const m = new THREE.Matrix4();
      const q = new THREE.Quaternion();
      const s = new THREE.Vector3();
      const mid = new THREE.Vector3();
      const colour = new THREE.Color();
      segments.count = 0;
      for (let i = 0; i + 1 < n; ++i) {
        const d = points[i + 1].clone().sub(points[i]);
        const len = d.length();
        if (len <= 0) continue;
        q.setFromUnitVectors(Z, d.divideScalar(len));
        mid.copy(points[i]).add(points[i + 1]).multiplyScalar(0.5);
        m.compose(mid, q, s.set(radius, radius, len));
        segments.setMatrixAt(segments.count, m);
        segments.setColorAt(segments.count, colour.set(colours[i]));
        segments.count += 1;
      }
      for (let i = 0; i < n; ++i) {
        m.compose(points[i], q.identity(), s.set(radius, radius, radius));
        joints.setMatrixAt(i, m);
        joints.setColorAt(i, colour.set(colours[Math.min(i, Math.max(n - 2, 0))]));
      }
      if (segments.count > 0) group.add(segments);
      group.add(joints);
      return group;
    }
    function tracePoints(base64) {
      const xyz = decode(base64, Float32Array);
      const points = [];
      for (let i = 0; i + 2 < xyz.length; i += 3) points.push(new THREE.Vector3(xyz[i], xyz[i + 1], xyz[i + 2]));
      return points;
    }

    const paths = data.inputs.concat(data.merged ? [data.merged] : []);
    for (const p of paths) {
      p.group = new THREE.Group();
      p.points = p.traces.map(tracePoints);
      const merged = p === data.merged;
      for (const points of p.points) {
        const colours = merged ? p.segment_colours : points.map(() => p.colour);
        p.group.add(tube(points, colours, size * (merged ? 0.0045 : 0.0016)));
      }
      scene.add(p.group);
      p.frameData = decode(p.frames, Float32Array);
    }

    const markers = new THREE.Group();
    const markerGeometry = new THREE.SphereGeometry(size * 0.009, 20, 12);
    for (const [key, colour] of [['start', 0x2ca02c], ['goal', 0x9467bd]]) {
      for (const xyz of data[key] || []) {
        const mk = new THREE.Mesh(markerGeometry, new THREE.MeshBasicMaterial({ color: colour }));
        mk.position.set(...xyz);
        markers.add(mk);
      }
    }
    scene.add(markers);

    const robotMaterial = new THREE.MeshStandardMaterial({
      color: data.robot_colour, roughness: 0.5, metalness: 0.1, side: THREE.DoubleSide,
    });
    const bodies = data.bodies.map((b) => {
      const mesh = new THREE.Mesh(shapeGeometry(b.shape), robotMaterial);
      scene.add(mesh);
      return mesh;
    });

    const camera = new THREE.PerspectiveCamera(40, 1, size * 0.001, size * 20);
    camera.up.set(0, 0, 1);
    const controls = new THREE.OrbitControls(camera, canvas);
    function homeView() {
      controls.target.copy(centre);
      const distance = size * (data.planar ? 1.25 : 1.3);
      // Planar scenes are seen from straight above with +y up, as the SVG pictures are.
      const dir = data.planar ? new THREE.Vector3(0, -1e-4, 1) : new THREE.Vector3(0.32, -1, 0.62);
      camera.position.copy(centre).addScaledVector(dir.normalize(), distance);
      controls.update();
    }
    homeView();
    controls.addEventListener('change', () => draw());

    // The robot rides one path: the merged path unless the legend picks an input.
    let rider = data.merged || data.inputs[0];
    let time = 0;  // fraction of the path's length
    let playing = false;
    let speed = 1;
    const q0 = new THREE.Quaternion();
    const q1 = new THREE.Quaternion();
    function poseRobot() {
      if (!rider) return;
      const frames = rider.frame_count;
      const stride = bodies.length * 7;
      const f = Math.min(Math.max(time, 0), 1) * (frames - 1);
      const a = Math.floor(f);
      const b = Math.min(a + 1, frames - 1);
      const t = f - a;
      const d = rider.frameData;
      bodies.forEach((mesh, k) => {
        const ia = a * stride + k * 7;
        const ib = b * stride + k * 7;
        mesh.position.set(d[ia], d[ia + 1], d[ia + 2]).lerp(new THREE.Vector3(d[ib], d[ib + 1], d[ib + 2]), t);
        q0.set(d[ia + 3], d[ia + 4], d[ia + 5], d[ia + 6]);
        q1.set(d[ib + 3], d[ib + 4], d[ib + 5], d[ib + 6]);
        mesh.quaternion.slerpQuaternions(q0, q1, t);
      });
    }

    function resize() {
      const w = canvas.clientWidth;
      const h = canvas.clientHeight;
      renderer.setSize(w, h, false);
      camera.aspect = w / Math.max(h, 1);
      camera.updateProjectionMatrix();
    }
    function draw() {
      poseRobot();
      renderer.render(scene, camera);
      slider.value = String(Math.round(time * 1000));
    }
    window.addEventListener('resize', () => { resize(); draw(); });

    // Controls.
    const seconds = 10;  // one pass along the path at 1x
    let last = null;
    function tick(now) {
      if (!playing) { last = null; return; }
      if (last !== null) {
        time += ((now - last) / 1000) * (speed / seconds);
        if (time >= 1) { time = 1; setPlaying(false); }
      }
      last = now;
      draw();
      if (playing) requestAnimationFrame(tick);
    }
    function setPlaying(on) {
      playing = on;
      play.textContent = on ? 'Pause' : 'Play';
      if (on) {
        if (time >= 1) time = 0;
        requestAnimationFrame(tick);
      }
    }
    play.addEventListener('click', () => setPlaying(!playing));
    window.addEventListener('keydown', (e) => {
      if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
      if (e.key === ' ') { e.preventDefault(); setPlaying(!playing); }
      if (e.key === 'ArrowRight' || e.key === 'ArrowLeft') {
        setPlaying(false);
        time = Math.min(1, Math.max(0, time + (e.key === 'ArrowRight' ? 0.01 : -0.01)));
        draw();
      }
    });
    slider.addEventListener('input', () => { time = Number(slider.value) / 1000; draw(); });
    speedSelect.addEventListener('change', () => { speed = Number(speedSelect.value); });
    document.getElementById('home').addEventListener('click', () => { homeView(); draw(); });
    document.getElementById('xray').addEventListener('change', (e) => {
      obstacleMaterial.transparent = e.target.checked;
      obstacleMaterial.opacity = e.target.checked ? 0.3 : 1;
      obstacleMaterial.depthWrite = !e.target.checked;
      obstacleMaterial.needsUpdate = true;
      draw();
    });

    buildLegend(data, paths, {
      show(p, on) { p.group.visible = on; draw(); },
      ride(p) { rider = p; time = 0; draw(); },
    });
    buildChart(data);

    resize();
    draw();

    api.setTime = (fraction) => { setPlaying(false); time = fraction; draw(); };
    api.project = (xyz) => {
      const v = new THREE.Vector3(...xyz).project(camera);
      const r = canvas.getBoundingClientRect();
      return [r.left + ((v.x + 1) / 2) * r.width, r.top + ((1 - v.y) / 2) * r.height, v.z];
    };
    // Points along the merged path's stretches (their middles) with the colour each is drawn in.
    api.mergedStretches = () => {
      const m = data.merged;
      if (!m) return [];
      const out = [];
      for (const points of m.points) {
        for (let i = 0; i + 1 < points.length; ++i) {
          const mid = points[i].clone().add(points[i + 1]).multiplyScalar(0.5);
          out.push({ xyz: mid.toArray(), colour: m.segment_colours[i], source: m.segment_sources[i] });
        }
      }
      return out;
    };
    // The screen rectangle [left, top, right, bottom] around the robot's bodies.
    api.robotScreenBox = () => {
      const box = new THREE.Box3();
      for (const b of bodies) box.expandByObject(b);
      let r = [Infinity, Infinity, -Infinity, -Infinity];
      for (let i = 0; i < 8; ++i) {
        const corner = [i & 1 ? box.max.x : box.min.x, i & 2 ? box.max.y : box.min.y, i & 4 ? box.max.z : box.min.z];
        const [x, y] = api.project(corner);
        r = [Math.min(r[0], x), Math.min(r[1], y), Math.max(r[2], x), Math.max(r[3], y)];
      }
      return r;
    };
    api.data = data;
  }

  function buildLegend(data, paths, actions) {
    const legend = document.getElementById('legend');
    legend.appendChild(element('h1', {}, data.title));
    if (data.measure) {
      const m = data.measure;
      const line = element('p', { class: 'measure', id: 'measure' });
      line.appendChild(document.createTextNode('measure: ' + m.name));
      if (m.objective !== undefined) {
        line.appendChild(element('span', { 'data-value': String(m.objective), id: 'objective' },
                                 ' objective ' + format(m.objective)));
      }
      if (m.best_input_objective !== undefined) {
        line.appendChild(document.createTextNode(', best input ' + format(m.best_input_objective)));
      }
      legend.appendChild(line);
    }
    const table = element('table');
    const head = element('tr');
    for (const h of ['', 'path', 'length', 'min clearance', 'show', 'ride']) head.appendChild(element('th', {}, h));
    table.appendChild(head);
    for (const p of paths) {
      const row = element('tr', { 'data-path': p.name, class: p === data.merged ? 'merged' : 'input' });
      const swatch = element('td');
      swatch.appendChild(element('span', { class: 'swatch', style: 'background:' + p.colour }));
      row.appendChild(swatch);
      row.appendChild(element('td', { class: 'name' }, p.name));
      row.appendChild(element('td', { class: 'length', 'data-value': String(p.length) }, format(p.length)));
      const clearance = p.has_clearance ? p.min_clearance : NaN;
      row.appendChild(element('td', { class: 'clearance', 'data-value': String(clearance) }, format(clearance)));
      const show = element('input', { type: 'checkbox', class: 'show' });
      show.checked = true;
      show.addEventListener('change', () => actions.show(p, show.checked));
      const cell = element('td');
      cell.appendChild(show);
      row.appendChild(cell);
      const ride = element('input', { type: 'radio', name: 'ride', class: 'ride' });
      ride.checked = p === data.merged || (!data.merged && p === paths[0]);
      ride.addEventListener('change', () => actions.ride(p));
      const rideCell = element('td');
      rideCell.appendChild(ride);
      row.appendChild(rideCell);
      table.appendChild(row);
    }
    legend.appendChild(table);
    if (data.merged && data.sources.length > 0) {
      const key = element('p', { class: 'sources' }, 'merged path from: ');
      for (const s of data.sources) {
        key.appendChild(element('span', { class: 'swatch', style: 'background:' + s.colour }));
        key.appendChild(document.createTextNode(s.label + '  '));
      }
      legend.appendChild(key);
    }
  }

  // Objective per round of the post-optimization against the merge's elapsed time.
  function buildChart(data) {
    const rounds = data.rounds || [];
    const box = document.getElementById('chart');
    if (rounds.length === 0) { box.remove(); return; }
    const W = 260, H = 150, L = 46, R = 10, T = 22, B = 28;
    const xs = rounds.map((r) => r.elapsed_ms);
    const ys = rounds.map((r) => r.objective);
    const x0 = Math.min(...xs), x1 = Math.max(...xs, x0 + 1e-9);
    let y0 = Math.min(...ys), y1 = Math.max(...ys);
    if (y1 - y0 < 1e-12) { y0 -= 0.5; y1 += 0.5; }
    const X = (x) => L + ((x - x0) / (x1 - x0 || 1)) * (W - L - R);
    const Y = (y) => T + (1 - (y - y0) / (y1 - y0)) * (H - T - B);
    const ns = 'http://www.w3.org/2000/svg';
    const svg = document.createElementNS(ns, 'svg');
    svg.setAttribute('viewBox', `0 0 ${W} ${H}`);
    svg.setAttribute('width', W);
    svg.setAttribute('height', H);
    const add = (tag, attrs, text) => {
      const e = document.createElementNS(ns, tag);
      for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
      if (text !== undefined) e.textContent = text;
      svg.appendChild(e);
      return e;
    };
    add('text', { x: 4, y: 14, class: 'title' }, 'post-optimization: objective by round');
    add('line', { x1: L, y1: H - B, x2: W - R, y2: H - B, class: 'axis' });
    add('line', { x1: L, y1: T, x2: L, y2: H - B, class: 'axis' });
    add('text', { x: L - 4, y: Y(y1) + 4, class: 'tick', 'text-anchor': 'end' }, format(y1));
    add('text', { x: L - 4, y: Y(y0) + 4, class: 'tick', 'text-anchor': 'end' }, format(y0));
    add('text', { x: L, y: H - 8, class: 'tick' }, x0.toFixed(1) + ' ms');
    add('text', { x: W - R, y: H - 8, class: 'tick', 'text-anchor': 'end' }, x1.toFixed(1) + ' ms');
    // Steps: the best objective holds until the next improvement.
    let d = '';
    rounds.forEach((r, i) => {
      d += (i === 0 ? 'M' : 'H') + X(r.elapsed_ms).toFixed(1) + (i === 0 ? ',' + Y(r.objective).toFixed(1) : '');
      if (i > 0) d += 'V' + Y(r.objective).toFixed(1);
    });
    add('path', { d, class: 'line' });
    for (const r of rounds) {
      const dot = add('circle', { cx: X(r.elapsed_ms), cy: Y(r.objective), r: 2.6, class: 'dot',
                                  'data-round': r.round, 'data-objective': r.objective });
      const tip = document.createElementNS(ns, 'title');
      tip.textContent = `round ${r.round}: ${format(r.objective)} at ${format(r.elapsed_ms)} ms`;
      dot.appendChild(tip);
    }
    box.appendChild(svg);
  }

  window.addEventListener('DOMContentLoaded', () => {
    try {
      const data = JSON.parse(document.getElementById('hgraph-view-data').textContent);
      build(data);
      // Ready once the browser has shown the first frame.
      requestAnimationFrame(() => requestAnimationFrame(() => { api.ready = true; }));
    } catch (e) {
      api.error = String(e && e.stack ? e.stack : e);
      const box = document.getElementById('legend');
      box.appendChild(element('p', { class: 'error' }, 'cannot show this view: ' + e));
      console.error(e);
      api.ready = true;
    }
  });
})();
