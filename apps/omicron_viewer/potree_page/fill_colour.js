// potree-core 2.0 draws a Potree 2.0 folder by its rgb attribute alone (its shader's new_format
// branch takes the colour from rgba whatever the colour type), so a folder without rgb comes out
// black, invisible on these pages' black background. Each loaded node without rgb gets a light
// grey rgba attribute instead.
import * as THREE from 'three';

// The loaded nodes of `pco` whose geometry lacks rgba get one; returns how many were filled.
export function fillMissingColour (pco) {
  let filled = 0;
  for (const node of pco.visibleNodes) {
    const g = node.geometryNode && node.geometryNode.geometry;
    if (!g || g.attributes.rgba || !g.attributes.position)
      continue;
    const rgba = new Uint8Array(4 * g.attributes.position.count).fill(200);
    g.setAttribute('rgba', new THREE.BufferAttribute(rgba, 4, true));
    ++filled;
  }
  return filled;
}
