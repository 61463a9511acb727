// Decoders for dfsm's result files, in plain JavaScript (no dependencies):
// float32 TIFF (depth.tiff, core/io/depth_tiff.cc), binary PLY (points.ply,
// core/export/ply.cc), SSE framing, and the turbo colour map of preview.png.

// --- TIFF -------------------------------------------------------------------
// Single-channel float32, strips, uncompressed (1) or Adobe/zlib deflate (8,
// 32946, inflated with the browser's DecompressionStream), predictor 1.
// Returns {width, height, data: Float32Array}.
export async function decodeFloatTiff(buffer) {
  const view = new DataView(buffer);
  const order = String.fromCharCode(view.getUint8(0), view.getUint8(1));
  if (order !== 'II' && order !== 'MM') throw new Error('not a TIFF file');
  const le = order === 'II';
  if (view.getUint16(2, le) !== 42) throw new Error('not a classic TIFF (BigTIFF is not supported)');
  const ifd = view.getUint32(4, le);
  const count = view.getUint16(ifd, le);
  const typeSize = {1: 1, 3: 2, 4: 4, 16: 8};
  const tags = new Map();
  for (let i = 0; i < count; i++) {
    const entry = ifd + 2 + 12 * i;
    const tag = view.getUint16(entry, le);
    const type = view.getUint16(entry + 2, le);
    const n = view.getUint32(entry + 4, le);
    const size = typeSize[type];
    if (!size) continue;  // a tag of a type we never need
    const at = size * n <= 4 ? entry + 8 : view.getUint32(entry + 8, le);
    const values = [];
    for (let k = 0; k < n; k++) {
      const p = at + k * size;
      values.push(type === 1 ? view.getUint8(p) : type === 3 ? view.getUint16(p, le)
                : type === 4 ? view.getUint32(p, le) : Number(view.getBigUint64(p, le)));
    }
    tags.set(tag, values);
  }
  const one = (tag, fallback) => (tags.has(tag) ? tags.get(tag)[0] : fallback);
  const width = one(256), height = one(257);
  const bits = one(258, 1), compression = one(259, 1), samples = one(277, 1);
  const format = one(339, 1), predictor = one(317, 1);
  if (!width || !height) throw new Error('TIFF without a size');
  if (bits !== 32 || format !== 3 || samples !== 1) throw new Error('TIFF is not single-channel float32');
  if (predictor !== 1) throw new Error(`TIFF predictor ${predictor} is not supported`);
  if (![1, 8, 32946].includes(compression)) throw new Error(`TIFF compression ${compression} is not supported`);
  const offsets = tags.get(273), counts = tags.get(279);
  if (!offsets || !counts || offsets.length !== counts.length) throw new Error('TIFF without strips');
  const out = new Uint8Array(width * height * 4);
  let filled = 0;
  for (let s = 0; s < offsets.length; s++) {
    let strip = new Uint8Array(buffer, offsets[s], counts[s]);
    if (compression !== 1) strip = await inflate(strip);
    const n = Math.min(strip.length, out.length - filled);
    out.set(strip.subarray(0, n), filled);
    filled += n;
  }
  if (filled !== out.length) throw new Error('TIFF strips hold fewer bytes than the image');
  const data = new Float32Array(width * height);
  const dv = new DataView(out.buffer);
  for (let i = 0; i < data.length; i++) data[i] = dv.getFloat32(4 * i, le);
  return {width, height, data};
}

async function inflate(bytes) {
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('deflate'));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}

// --- PLY --------------------------------------------------------------------
// Binary (little or big endian) PLY; reads the vertex element's x, y, z and,
// when present, red, green, blue. Returns {count, positions: Float32Array(3n),
// colors: Uint8Array(3n) | null}.
const PLY_TYPES = {
  char: ['getInt8', 1], int8: ['getInt8', 1], uchar: ['getUint8', 1], uint8: ['getUint8', 1],
  short: ['getInt16', 2], int16: ['getInt16', 2], ushort: ['getUint16', 2], uint16: ['getUint16', 2],
  int: ['getInt32', 4], int32: ['getInt32', 4], uint: ['getUint32', 4], uint32: ['getUint32', 4],
  float: ['getFloat32', 4], float32: ['getFloat32', 4], double: ['getFloat64', 8], float64: ['getFloat64', 8],
};

export function parsePly(buffer) {
  const bytes = new Uint8Array(buffer);
  const marker = 'end_header';
  let end = -1;
  for (let i = 0; i + marker.length < Math.min(bytes.length, 65536); i++) {
    let match = true;
    for (let k = 0; k < marker.length && match; k++) match = bytes[i + k] === marker.charCodeAt(k);
    if (match) { end = i + marker.length; break; }
  }
  if (end < 0) throw new Error('not a PLY file (no end_header)');
  while (end < bytes.length && bytes[end] !== 0x0a) end++;
  const header = new TextDecoder().decode(bytes.subarray(0, end)).split(/\r?\n/);
  end++;  // past the newline
  if (header[0].trim() !== 'ply') throw new Error('not a PLY file');
  let le = true;
  const elements = [];
  for (const line of header) {
    const w = line.trim().split(/\s+/);
    if (w[0] === 'format') {
      if (w[1] === 'binary_little_endian') le = true;
      else if (w[1] === 'binary_big_endian') le = false;
      else throw new Error(`PLY format '${w[1]}' is not supported (binary only)`);
    } else if (w[0] === 'element') {
      elements.push({name: w[1], count: Number(w[2]), properties: [], stride: 0});
    } else if (w[0] === 'property' && elements.length) {
      if (w[1] === 'list') throw new Error('PLY list properties are not supported before the vertices');
      const type = PLY_TYPES[w[1]];
      if (!type) throw new Error(`unknown PLY type '${w[1]}'`);
      const el = elements[elements.length - 1];
      el.properties.push({name: w[2], get: type[0], offset: el.stride});
      el.stride += type[1];
    }
  }
  let offset = end;
  for (const el of elements) {
    if (el.name === 'vertex') break;
    offset += el.count * el.stride;  // fixed-size elements before the vertices
  }
  const vertex = elements.find((e) => e.name === 'vertex');
  if (!vertex) throw new Error('PLY without vertices');
  const prop = (name) => vertex.properties.find((p) => p.name === name);
  const px = prop('x'), py = prop('y'), pz = prop('z');
  if (!px || !py || !pz) throw new Error('PLY vertices without x, y, z');
  const pr = prop('red'), pg = prop('green'), pb = prop('blue');
  const count = Math.min(vertex.count, Math.floor((bytes.length - offset) / vertex.stride));
  const view = new DataView(buffer);
  const positions = new Float32Array(3 * count);
  const colors = pr && pg && pb ? new Uint8Array(3 * count) : null;
  for (let i = 0; i < count; i++) {
    const base = offset + i * vertex.stride;
    positions[3 * i] = view[px.get](base + px.offset, le);
    positions[3 * i + 1] = view[py.get](base + py.offset, le);
    positions[3 * i + 2] = view[pz.get](base + pz.offset, le);
    if (colors) {
      colors[3 * i] = view[pr.get](base + pr.offset, le);
      colors[3 * i + 1] = view[pg.get](base + pg.offset, le);
      colors[3 * i + 2] = view[pb.get](base + pb.offset, le);
    }
  }
  return {count, declared: vertex.count, positions, colors};
}

// --- Server-Sent Events framing -----------------------------------------------
// Feed text as it arrives; calls onEvent({event, data}) per complete event and
// onRetry(ms) for a retry field (https://html.spec.whatwg.org/#event-stream-interpretation).
export class SseParser {
  constructor(onEvent, onRetry = () => {}) {
    this.buffer = '';
    this.onEvent = onEvent;
    this.onRetry = onRetry;
    this.reset();
  }
  reset() { this.event = ''; this.data = []; }
  push(text) {
    this.buffer += text;
    let nl;
    while ((nl = this.buffer.search(/\r\n|\r|\n/)) >= 0) {
      const line = this.buffer.slice(0, nl);
      const skip = this.buffer.startsWith('\r\n', nl) ? 2 : 1;
      this.buffer = this.buffer.slice(nl + skip);
      this.line(line);
    }
  }
  line(line) {
    if (line === '') {
      if (this.data.length) this.onEvent({event: this.event || 'message', data: this.data.join('\n')});
      this.reset();
      return;
    }
    if (line.startsWith(':')) return;
    const colon = line.indexOf(':');
    const field = colon < 0 ? line : line.slice(0, colon);
    let value = colon < 0 ? '' : line.slice(colon + 1);
    if (value.startsWith(' ')) value = value.slice(1);
    if (field === 'event') this.event = value;
    else if (field === 'data') this.data.push(value);
    else if (field === 'retry' && /^\d+$/.test(value)) this.onRetry(Number(value));
  }
}

// --- Colour map ---------------------------------------------------------------
// Google's turbo (polynomial fit), as preview.png uses it: 0 blue (far), 1 red (near).
export function turbo(x) {
  x = Math.min(1, Math.max(0, x));
  const r = 0.13572138 + x * (4.6153926 + x * (-42.66032258 + x * (132.13108234 + x * (-152.94239396 + x * 59.28637943))));
  const g = 0.09140261 + x * (2.19418839 + x * (4.84296658 + x * (-14.18503333 + x * (4.27729857 + x * 2.82956604))));
  const b = 0.1066733 + x * (12.64194608 + x * (-60.58204836 + x * (110.36276771 + x * (-89.90310912 + x * 27.34824973))));
  const c = (v) => Math.round(255 * Math.min(1, Math.max(0, v)));
  return [c(r), c(g), c(b)];
}

export const TURBO_LUT = (() => {
  const lut = new Uint8Array(256 * 3);
  for (let i = 0; i < 256; i++) lut.set(turbo(i / 255), 3 * i);
  return lut;
})();
