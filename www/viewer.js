// The 3-D view of points.ply: three.js (vendored, www/vendor/, scripts/vendor-www.sh)
// with a small orbit of its own: drag rotates about the cloud's centre, the
// wheel zooms, a double click returns to the reference camera's view. On a
// touch screen one finger across rotates, one finger up or down scrolls the
// page (the canvas's touch-action is pan-y, so the viewer never traps it),
// two fingers pinch to zoom and a double tap returns.
// Loaded on demand (import() from app.js), so the first page load stays small.
import * as THREE from './vendor/three.module.min.js';

export class PointViewer {
  constructor(canvas) {
    this.canvas = canvas;
    // preserveDrawingBuffer: the canvas can be read back (tests, screenshots).
    this.renderer = new THREE.WebGLRenderer({canvas, antialias: false, preserveDrawingBuffer: true});
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.setClearColor(0x11151c, 1);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(50, 1, 0.001, 1000);
    this.camera.up.set(0, -1, 0);  // image y points down in the camera frame
    this.target = new THREE.Vector3();
    this.radius = 1;
    this.theta = 0;              // about the vertical axis
    this.phi = Math.PI / 2;      // from the up axis; pi/2 = level
    this.points = null;
    this.pending = false;
    this.bindInput();
    this.resizeObserver = new ResizeObserver(() => this.resize());
    this.resizeObserver.observe(canvas);
    this.resize();
  }

  // cloud: {count, positions: Float32Array, colors: Uint8Array|null}
  setCloud(cloud) {
    if (this.points) {
      this.scene.remove(this.points);
      this.points.geometry.dispose();
      this.points.material.dispose();
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(cloud.positions, 3));
    if (cloud.colors) geometry.setAttribute('color', new THREE.BufferAttribute(cloud.colors, 3, true));
    geometry.computeBoundingSphere();
    const material = new THREE.PointsMaterial({size: 2, sizeAttenuation: false, vertexColors: !!cloud.colors,
                                               color: cloud.colors ? 0xffffff : 0x9fd3ff});
    this.points = new THREE.Points(geometry, material);
    this.scene.add(this.points);
    // Orbit about the median point (robust to a few stray far points).
    const median = (axis) => {
      const step = Math.max(1, Math.floor(cloud.count / 5000));
      const v = [];
      for (let i = 0; i < cloud.count; i += step) v.push(cloud.positions[3 * i + axis]);
      v.sort((a, b) => a - b);
      return v.length ? v[v.length >> 1] : 0;
    };
    this.home = {target: new THREE.Vector3(median(0), median(1), median(2))};
    // From the reference camera (the origin) to the centre.
    this.home.radius = Math.max(this.home.target.length(), 1e-3);
    this.home.theta = Math.atan2(-this.home.target.x, this.home.target.z);
    this.home.phi = Math.PI / 2;
    this.camera.near = this.home.radius / 1000;
    this.camera.far = this.home.radius * 100;
    this.camera.updateProjectionMatrix();
    this.resetView();
  }

  resetView() {
    if (!this.home) return;
    this.target.copy(this.home.target);
    this.radius = this.home.radius;
    this.theta = this.home.theta;
    this.phi = this.home.phi;
    this.requestRender();
  }

  bindInput() {
    const c = this.canvas;
    const pointers = new Map();  // pointerId -> {x, y}, the pointers down on the canvas
    let pinch = 0;               // the two touches' distance at the last move
    let lastTap = 0;
    const spread = () => {
      const [a, b] = [...pointers.values()];
      return Math.hypot(a.x - b.x, a.y - b.y);
    };
    c.addEventListener('pointerdown', (e) => {
      pointers.set(e.pointerId, {x: e.clientX, y: e.clientY});
      c.setPointerCapture(e.pointerId);
      if (pointers.size === 2) pinch = spread();
      if (e.pointerType === 'touch' && pointers.size === 1) {
        if (e.timeStamp - lastTap < 300) this.resetView();
        lastTap = e.timeStamp;
      }
    });
    c.addEventListener('pointermove', (e) => {
      const last = pointers.get(e.pointerId);
      if (!last) return;
      const dx = e.clientX - last.x, dy = e.clientY - last.y;
      pointers.set(e.pointerId, {x: e.clientX, y: e.clientY});
      if (pointers.size === 2) {
        const now = spread();
        if (pinch > 0 && now > 0) this.radius *= pinch / now;
        pinch = now;
      } else if (pointers.size === 1) {
        this.theta -= dx * 0.008;
        // A finger's vertical motion scrolls the page (touch-action: pan-y).
        if (e.pointerType !== 'touch') this.phi = Math.min(Math.PI - 0.05, Math.max(0.05, this.phi - dy * 0.008));
      }
      this.requestRender();
    });
    const end = (e) => {
      pointers.delete(e.pointerId);
      pinch = pointers.size === 2 ? spread() : 0;
      if (c.hasPointerCapture(e.pointerId)) c.releasePointerCapture(e.pointerId);
    };
    c.addEventListener('pointerup', end);
    c.addEventListener('pointercancel', end);
    c.addEventListener('wheel', (e) => {
      e.preventDefault();
      this.radius *= Math.exp(Math.sign(e.deltaY) * Math.min(Math.abs(e.deltaY), 200) * 0.002);
      this.requestRender();
    }, {passive: false});
    c.addEventListener('dblclick', () => this.resetView());
  }

  resize() {
    const w = Math.max(1, this.canvas.clientWidth), h = Math.max(1, this.canvas.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  requestRender() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => { this.pending = false; this.render(); });
  }

  render() {
    // Spherical offset in a frame whose up is -y and whose theta=0 looks along +z.
    const s = Math.sin(this.phi);
    const offset = new THREE.Vector3(s * Math.sin(this.theta), -Math.cos(this.phi), -s * Math.cos(this.theta))
        .multiplyScalar(this.radius);
    this.camera.position.copy(this.target).add(offset);
    this.camera.lookAt(this.target);
    this.renderer.render(this.scene, this.camera);
    this.canvas.dataset.rendered = this.points ? String(this.points.geometry.attributes.position.count) : '0';
  }

  dispose() {
    this.resizeObserver.disconnect();
    if (this.points) { this.points.geometry.dispose(); this.points.material.dispose(); }
    this.renderer.dispose();
  }
}
