// Reading the glb (glTF 2.0 binary) the service writes: typed arrays straight over the
// file's BIN chunk, no copy. Layers by primitive extras: cells, edges, lines, points.

const COMPONENTS = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4 };
const ARRAYS = { 5126: Float32Array, 5125: Uint32Array, 5123: Uint16Array, 5121: Uint8Array };

export function parseGlb(buffer) {
  const dv = new DataView(buffer);
  if (dv.getUint32(0, true) !== 0x46546c67 || dv.getUint32(4, true) !== 2) {
    throw new Error("not a glTF 2.0 binary file");
  }
  const jsonLength = dv.getUint32(12, true);
  const gltf = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 20, jsonLength)));
  const bin = 20 + jsonLength + 8;
  const accessor = (i) => {
    if (i === undefined) return null;
    const a = gltf.accessors[i];
    const view = gltf.bufferViews[a.bufferView];
    const Ctor = ARRAYS[a.componentType];
    const offset = bin + (view.byteOffset || 0) + (a.byteOffset || 0);
    return { array: new Ctor(buffer, offset, a.count * COMPONENTS[a.type]), min: a.min, max: a.max, count: a.count };
  };
  const primitives = gltf.meshes[0].primitives.map((p) => ({
    layer: p.extras?.layer || (p.mode === 1 ? "lines" : p.mode === 0 ? "points" : "cells"),
    mode: p.mode ?? 4,
    position: accessor(p.attributes.POSITION),
    quality: accessor(p.attributes._QUALITY),
    radius: accessor(p.attributes._RADIUS),
    indices: accessor(p.indices),
    cellTypes: p.extras?.cell_types || [],
  }));
  return { gltf, translation: gltf.nodes?.[0]?.translation || [0, 0, 0], primitives, extras: gltf.extras || {} };
}
