// The 3-D view of a rigfit report (report/view3d.h): reads the scene RIGFIT_VIEW that
// view3d_data.js sets and draws it with three.js (global THREE and THREE.OrbitControls, both
// copied beside the page). Works from file://: nothing is fetched. The URL hash picks the
// start: #poses=0 (index of the pose set), color=camera|residual|rgb|height,
// layers=band,whole,planes (planes: the surface bundle's, off by default), size=2 (pixels).
// When drawn with every layer switched on, the body gets data-status="ready" and
// data-ready-ms (time since navigation), data-planes the number of planes shown; errors go to
// data-errors.
(function () {
  'use strict';
  const V = window.RIGFIT_VIEW;
  const body = document.body;

  // ---- data ----
  function Decode(b64, Type) {
    const s = atob(b64);
    const bytes = new Uint8Array(s.length);
    for (let i = 0; i < s.length; ++i) bytes[i] = s.charCodeAt(i);
    return new Type(bytes.buffer);
  }
  function HashOptions() {
    const o = {};
    for (const part of window.location.hash.replace(/^#/, '').split('&')) {
      const eq = part.indexOf('=');
      if (eq > 0) o[decodeURIComponent(part.slice(0, eq))] = decodeURIComponent(part.slice(eq + 1));
    }
    return o;
  }
  const hash = HashOptions();
  const hasResiduals = V.clouds.some(c => c.residuals.length > 0);
  const hasRgb = V.has_rgb;  // of the deferred clouds too
  const isRig = V.clouds.some(c => c.layer === 'band');
  const state = {
    pose: Math.max(0, Math.min(V.pose_sets.length - 1,
                               hash.poses !== undefined ? parseInt(hash.poses, 10) : V.pose_sets.length - 1)),
    color: hash.color || (isRig ? 'camera' : (hasRgb ? 'rgb' : 'height')),
    layers: new Set((hash.layers || (isRig ? 'band' : 'map')).split(',')),
    size: parseFloat(hash.size || (isRig ? '3' : '2')),
  };

  // ---- scene ----
  const renderer = new THREE.WebGLRenderer({antialias: false});
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(window.innerWidth, window.innerHeight);
  body.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xffffff);
  // The world turned so that V.up is +Y, and moved so that the floor is y = 0.
  const world = new THREE.Group();
  world.quaternion.setFromUnitVectors(new THREE.Vector3().fromArray(V.up), new THREE.Vector3(0, 1, 0));
  world.position.y = -V.floor_m;
  scene.add(world);
  world.updateMatrixWorld(true);

  const cameraGroups = V.cameras.map(() => {
    const g = new THREE.Group();
    g.matrixAutoUpdate = false;
    world.add(g);
    return g;
  });
  function MakeCloud(c) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(Decode(c.positions, Int16Array), 3));
    const colors = new THREE.BufferAttribute(new Uint8Array(3 * c.count), 3, true);
    geometry.setAttribute('color', colors);
    const material = new THREE.PointsMaterial({size: state.size, sizeAttenuation: false,
                                               vertexColors: THREE.VertexColors});
    const points = new THREE.Points(geometry, material);
    points.position.fromArray(c.origin);
    points.scale.setScalar(c.step);
    (c.camera >= 0 ? cameraGroups[c.camera] : world).add(points);
    return {data: c, points: points, colors: colors,
            rgb: c.rgb ? Decode(c.rgb, Uint8Array) : null,
            residuals: c.residuals.map(r => Decode(r, Uint8Array))};
  }
  const clouds = V.clouds.map(MakeCloud);
  // Layers written to a script of their own (the whole views), loaded when switched on.
  const deferred = V.deferred || {};
  let pending = 0;
  function LoadDeferred(layer) {
    const file = deferred[layer];
    if (!file) return;
    delete deferred[layer];
    ++pending;
    const script = document.createElement('script');
    script.src = file;
    script.onload = () => {
      for (const c of window.RIGFIT_VIEW_WHOLE) clouds.push(MakeCloud(c));
      --pending;
      Update();
    };
    document.head.appendChild(script);
  }

  // Frustums: apex at the camera, the image rectangle at `depth`, a triangle on its top edge.
  function FrustumVertices(cam, depth) {
    const K = cam.K;
    const w = cam.width > 0 ? cam.width : 2, h = cam.height > 0 ? cam.height : 2;
    const corner = (u, v) => cam.width > 0
        ? new THREE.Vector3((u - K[2]) / K[0] * depth, (v - K[3]) / K[1] * depth, depth)
        : new THREE.Vector3((u - 1) * 0.577 * depth, (v - 1) * 0.577 * depth, depth);
    const c = [corner(0, 0), corner(w, 0), corner(w, h), corner(0, h)];
    const o = new THREE.Vector3();
    const top = corner(w / 2, -0.25 * h);
    return [o, c[0], o, c[1], o, c[2], o, c[3], c[0], c[1], c[1], c[2], c[2], c[3], c[3], c[0],
            c[0], top, top, c[1]];
  }
  const paths = V.paths.map(p => {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(Decode(p.positions, Float32Array), 3));
    const line = new THREE.Line(geometry, new THREE.LineBasicMaterial({
      color: new THREE.Color(p.color[0] / 255, p.color[1] / 255, p.color[2] / 255)}));
    world.add(line);
    return line;
  });
  // The surface bundle's planes: translucent convex patches in the world (a triangle fan each)
  // with their outline, under the layer 'planes'.
  const planes = (V.planes || []).map(p => {
    const xyz = Decode(p.corners, Float32Array);
    const n = xyz.length / 3;
    const index = [];
    for (let i = 1; i + 1 < n; ++i) index.push(0, i, i + 1);
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
    geometry.setIndex(index);
    const color = new THREE.Color(p.color[0] / 255, p.color[1] / 255, p.color[2] / 255);
    const patch = new THREE.Group();
    patch.add(new THREE.Mesh(geometry, new THREE.MeshBasicMaterial({
      color: color, transparent: true, opacity: p.floor ? 0.2 : 0.35, side: THREE.DoubleSide,
      depthWrite: false})));
    const outline = new THREE.BufferGeometry();  // the corners in order, not the fan's triangles
    outline.setAttribute('position', geometry.getAttribute('position'));
    patch.add(new THREE.LineLoop(outline, new THREE.LineBasicMaterial({color: color})));
    world.add(patch);
    return patch;
  });
  function SetPoses() {
    if (V.pose_sets.length === 0) return;
    V.pose_sets[state.pose].poses.forEach((m, i) => {
      cameraGroups[i].matrix.fromArray(m);
      cameraGroups[i].matrixWorldNeedsUpdate = true;
    });
    scene.updateMatrixWorld(true);
  }
  SetPoses();
  const box = new THREE.Box3();
  for (const c of clouds) if (c.data.layer !== 'whole') box.expandByObject(c.points);
  for (const p of paths) box.expandByObject(p);
  for (const g of cameraGroups) box.expandByPoint(new THREE.Vector3().setFromMatrixPosition(g.matrixWorld));
  if (box.isEmpty()) box.set(new THREE.Vector3(-1, 0, -1), new THREE.Vector3(1, 1, 1));
  const centre = box.getCenter(new THREE.Vector3());
  const radius = Math.max(0.5, 0.5 * box.getSize(new THREE.Vector3()).length());

  const frustumDepth = Math.min(0.5, Math.max(0.1, 0.08 * radius));
  V.cameras.forEach((cam, i) => {
    const geometry = new THREE.BufferGeometry().setFromPoints(FrustumVertices(cam, frustumDepth));
    cameraGroups[i].add(new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({
      color: new THREE.Color(cam.color[0] / 255, cam.color[1] / 255, cam.color[2] / 255)})));
  });

  function NiceStep(x) {
    const p = Math.pow(10, Math.floor(Math.log10(x)));
    const f = x / p;
    return (f < 1.5 ? 1 : f < 3.5 ? 2 : f < 7.5 ? 5 : 10) * p;
  }
  const cell = NiceStep(radius / 8);
  const cells = 2 * Math.ceil(1.5 * radius / cell);
  // The grid's lines in one colour, so that they share the frustums' shader (one fewer to
  // compile: the slowest part of opening the page under a software renderer).
  const gridLines = [];
  for (let i = -cells / 2; i <= cells / 2; ++i) {
    const a = i * cell, b = cells / 2 * cell;
    gridLines.push(new THREE.Vector3(a, 0, -b), new THREE.Vector3(a, 0, b),
                   new THREE.Vector3(-b, 0, a), new THREE.Vector3(b, 0, a));
  }
  const grid = new THREE.LineSegments(new THREE.BufferGeometry().setFromPoints(gridLines),
                                      new THREE.LineBasicMaterial({color: 0xd0d0d0}));
  grid.position.set(Math.round(centre.x / cell) * cell, 0, Math.round(centre.z / cell) * cell);
  scene.add(grid);

  const camera = new THREE.PerspectiveCamera(50, window.innerWidth / window.innerHeight,
                                             radius / 1000, radius * 100);
  camera.position.copy(centre).add(new THREE.Vector3(0.3, 1.0, 1.2).normalize().multiplyScalar(1.6 * radius));
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  controls.target.copy(centre);
  controls.update();

  // ---- colours ----
  const kRamp = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
  function Ramp(t, out, k) {
    const x = Math.max(0, Math.min(1, t)) * (kRamp.length - 1);
    const i = Math.min(kRamp.length - 2, Math.floor(x)), f = x - i;
    for (let j = 0; j < 3; ++j) out[k + j] = kRamp[i][j] + f * (kRamp[i + 1][j] - kRamp[i][j]);
  }
  function HeightRange() {
    const sample = [];
    const v = new THREE.Vector3();
    for (const c of clouds) {
      if (!c.points.visible) continue;
      const pos = c.points.geometry.attributes.position;
      const stride = Math.max(1, Math.floor(pos.count / 5000));
      for (let i = 0; i < pos.count; i += stride) {
        sample.push(v.fromBufferAttribute(pos, i).applyMatrix4(c.points.matrixWorld).y);
      }
    }
    sample.sort((a, b) => a - b);
    if (sample.length === 0) return [0, 1];
    const lo = sample[Math.floor(0.01 * (sample.length - 1))];
    const hi = sample[Math.floor(0.99 * (sample.length - 1))];
    return [lo, Math.max(hi, lo + 1e-3)];
  }
  function Fill(c, range) {
    const out = c.colors.array, n = c.data.count;
    const camColor = c.data.camera >= 0 ? V.cameras[c.data.camera].color : [120, 120, 120];
    if (state.color === 'rgb' && c.rgb) {
      out.set(c.rgb);
    } else if (state.color === 'residual' && c.residuals.length > 0) {
      const r = c.residuals[state.pose];
      for (let i = 0; i < n; ++i) {
        if (r[i] === 255) { out[3 * i] = out[3 * i + 1] = out[3 * i + 2] = 200; continue; }
        Ramp(r[i] / 254, out, 3 * i);
      }
    } else if (state.color === 'height') {
      // The world height y of each point: the second row of its matrix times its position.
      const p = c.points.geometry.attributes.position.array, e = c.points.matrixWorld.elements;
      const scale = 1 / (range[1] - range[0]);
      for (let i = 0; i < n; ++i) {
        const y = e[1] * p[3 * i] + e[5] * p[3 * i + 1] + e[9] * p[3 * i + 2] + e[13];
        Ramp((y - range[0]) * scale, out, 3 * i);
      }
    } else {
      const grey = state.color === 'residual' ? [200, 200, 200] : camColor;
      for (let i = 0; i < n; ++i) out.set(grey, 3 * i);
    }
    c.colors.needsUpdate = true;
  }
  function Recolor() {
    for (const layer of state.layers) LoadDeferred(layer);
    for (const c of clouds) c.points.visible = state.layers.has(c.data.layer);
    for (const p of planes) p.visible = state.layers.has('planes');
    const range = state.color === 'height' ? HeightRange() : null;
    for (const c of clouds) if (c.points.visible) Fill(c, range);
    for (const c of clouds) c.points.material.size = state.size * (c.data.layer === 'whole' ? 0.6 : 1);
    ui.Legend(range);
  }

  // ---- user interface ----
  const ui = BuildUi();
  function Element(tag, parent, text, css) {
    const e = document.createElement(tag);
    if (text) e.textContent = text;
    if (css) e.style.cssText = css;
    if (parent) parent.appendChild(e);
    return e;
  }
  function BuildUi() {
    const style = Element('style', document.head);
    style.textContent =
        'body{margin:0;overflow:hidden;font:13px sans-serif;color:#111}' +
        '#panel{position:absolute;top:8px;left:8px;background:rgba(255,255,255,.9);' +
        'border:1px solid #ccc;padding:8px;max-width:300px;max-height:95vh;overflow:auto}' +
        '#panel h1{font-size:15px;margin:0 0 6px}#panel h2{font-size:13px;margin:8px 0 3px}' +
        '.label{position:absolute;font:12px sans-serif;padding:0 3px;background:rgba(255,255,255,.8);' +
        'pointer-events:none;white-space:nowrap}' +
        '#scale{position:absolute;left:12px;bottom:12px;font:12px sans-serif}' +
        '#scale div{height:6px;border:2px solid #111;border-top:none}';
    const panel = Element('div', body);
    panel.id = 'panel';
    Element('h1', panel, V.title);
    const r = {};
    if (V.pose_sets.length > 1) {
      Element('h2', panel, 'Poses');
      r.poseButtons = V.pose_sets.map((set, i) => {
        const b = Element('button', panel, set.name, 'margin:1px');
        b.onclick = () => { state.pose = i; Update(); };
        return b;
      });
    }
    Element('h2', panel, 'Points');
    for (const layer of ['band', 'whole', 'map']) {
      if (!V.clouds.some(c => c.layer === layer) && !deferred[layer]) continue;
      const l = Element('label', panel, '', 'display:block');
      const box = Element('input', l);
      box.type = 'checkbox';
      box.checked = state.layers.has(layer);
      box.onchange = () => { box.checked ? state.layers.add(layer) : state.layers.delete(layer); Update(); };
      l.append({band: ' near-floor band', whole: ' whole view', map: ' map'}[layer]);
    }
    if (planes.length > 0) {
      // The surface bundle's planes, where its pixels lie at the refined poses.
      const l = Element('label', panel, '', 'display:block');
      const box = Element('input', l);
      box.type = 'checkbox';
      box.checked = state.layers.has('planes');
      box.onchange = () => { box.checked ? state.layers.add('planes') : state.layers.delete('planes'); Update(); };
      l.append(' surface bundle planes (' + planes.length + ', at the refined poses)');
    }
    const select = Element('select', Element('label', panel, 'colour ', 'display:block'));
    const modes = [['camera', 'per camera'], ['residual', 'by residual'], ['rgb', 'capture colour'],
                   ['height', 'by height']].filter(m =>
        (m[0] !== 'camera' || V.cameras.length > 0) && (m[0] !== 'residual' || hasResiduals) &&
        (m[0] !== 'rgb' || hasRgb));
    for (const m of modes) Element('option', select, m[1]).value = m[0];
    if (!modes.some(m => m[0] === state.color)) state.color = modes[0][0];
    select.value = state.color;
    select.onchange = () => { state.color = select.value; Update(); };
    const size = Element('input', Element('label', panel, 'point size ', 'display:block'));
    Object.assign(size, {type: 'range', min: 1, max: 8, step: 0.5, value: state.size});
    size.oninput = () => { state.size = parseFloat(size.value); Recolor(); Render(); };
    r.legend = Element('div', panel);
    Element('h2', panel, 'Measure');
    r.measure = Element('div', panel, 'click two points: their distance');
    Element('div', panel, 'grid cells ' + cell + ' m, +Y up; drag to orbit, ' +
            'right-drag to pan, wheel to zoom', 'color:#555;margin-top:6px');
    r.scale = Element('div', body);
    r.scale.id = 'scale';
    r.scaleBar = Element('div', r.scale);
    r.scaleText = Element('span', r.scale);
    r.labels = V.cameras.map(cam => {
      const l = Element('div', body, cam.serial);
      l.className = 'label';
      l.style.borderLeft = '4px solid rgb(' + cam.color.join(',') + ')';
      return l;
    });
    r.Legend = range => {
      r.legend.textContent = '';
      if (r.poseButtons) r.poseButtons.forEach((b, i) => { b.style.fontWeight = i === state.pose ? 'bold' : ''; });
      if (state.color === 'camera' || state.color === 'rgb') {  // rgb: points without any by camera
        for (const cam of V.cameras) {
          const row = Element('div', r.legend);
          Element('span', row, '', 'display:inline-block;width:12px;height:12px;margin-right:5px;' +
                  'background:rgb(' + cam.color.join(',') + ')');
          row.append(cam.serial);
        }
      } else if (state.color === 'residual' || state.color === 'height') {
        const stops = [];
        const c = [0, 0, 0];
        for (let t = 0; t <= 1.0001; t += 0.25) { Ramp(t, c, 0); stops.push('rgb(' + c.map(Math.round).join(',') + ')'); }
        Element('div', r.legend, '', 'height:10px;margin-top:6px;background:linear-gradient(to right,' + stops.join(',') + ')');
        Element('div', r.legend, state.color === 'residual'
            ? '|residual| 0 to ' + (V.residual_range_m * 1e3).toFixed(1) + ' mm (grey: no match)'
            : 'height ' + range[0].toFixed(2) + ' to ' + range[1].toFixed(2) + ' m');
      }
    };
    return r;
  }

  // ---- measuring: click two points ----
  const raycaster = new THREE.Raycaster();
  const marks = new THREE.Group();
  scene.add(marks);
  let picks = [], down = null;
  renderer.domElement.addEventListener('pointerdown', e => { down = [e.clientX, e.clientY]; });
  renderer.domElement.addEventListener('pointerup', e => {
    if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 3) return;
    const mouse = new THREE.Vector2(e.clientX / window.innerWidth * 2 - 1, -e.clientY / window.innerHeight * 2 + 1);
    raycaster.setFromCamera(mouse, camera);
    raycaster.params.Points.threshold = 0.005 * camera.position.distanceTo(controls.target);
    const hit = raycaster.intersectObjects(clouds.filter(c => c.points.visible).map(c => c.points))[0];
    if (!hit) return;
    if (picks.length === 2) picks = [];
    picks.push(hit.point.clone());
    marks.clear ? marks.clear() : marks.children.slice().forEach(m => marks.remove(m));
    const geometry = new THREE.BufferGeometry().setFromPoints(picks);
    marks.add(new THREE.Points(geometry, new THREE.PointsMaterial({color: 0xe00000, size: 9, sizeAttenuation: false})));
    if (picks.length === 2) {
      marks.add(new THREE.Line(geometry, new THREE.LineBasicMaterial({color: 0xe00000})));
      ui.measure.textContent = 'distance ' + picks[0].distanceTo(picks[1]).toFixed(3) + ' m';
    } else {
      ui.measure.textContent = 'first point picked; click a second';
    }
    Render();
  });

  // ---- drawing ----
  function Render() {
    renderer.render(scene, camera);
    const w = window.innerWidth, h = window.innerHeight;
    V.cameras.forEach((cam, i) => {
      const p = new THREE.Vector3().setFromMatrixPosition(cameraGroups[i].matrixWorld).project(camera);
      const label = ui.labels[i];
      label.style.display = p.z < 1 && Math.abs(p.x) < 1 && Math.abs(p.y) < 1 ? '' : 'none';
      label.style.left = ((p.x + 1) / 2 * w + 6) + 'px';
      label.style.top = ((1 - p.y) / 2 * h - 8) + 'px';
    });
    // Scale bar at the depth of the orbit centre.
    const pxPerM = h / (2 * camera.position.distanceTo(controls.target) *
                        Math.tan(THREE.MathUtils ? THREE.MathUtils.degToRad(camera.fov / 2) : camera.fov * Math.PI / 360));
    const length = NiceStep(120 / pxPerM);
    ui.scaleBar.style.width = (length * pxPerM) + 'px';
    ui.scaleText.textContent = (length >= 1 ? length + ' m' : Math.round(length * 1000) + ' mm') +
        ' at the orbit centre';
  }
  function Update() {
    SetPoses();
    Recolor();
    Render();
    body.setAttribute('data-pose', V.pose_sets.length ? V.pose_sets[state.pose].name : '');
    body.setAttribute('data-color', state.color);
    body.setAttribute('data-planes', String(planes.filter(p => p.visible).length));
    body.setAttribute('data-points',
                      String(clouds.reduce((n, c) => n + (c.points.visible ? c.data.count : 0), 0)));
    if (pending === 0) {
      body.setAttribute('data-ready-ms', String(Math.round(performance.now())));
      body.setAttribute('data-status', 'ready');
    }
  }
  controls.addEventListener('change', Render);
  window.addEventListener('resize', () => {
    camera.aspect = window.innerWidth / window.innerHeight;
    camera.updateProjectionMatrix();
    renderer.setSize(window.innerWidth, window.innerHeight);
    Render();
  });
  Update();
})();
