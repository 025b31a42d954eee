// What the layers of the 3D view (viewer3d.js and its model3d.js, frames3d.js, pick3d.js, reality3d.js) share:
// the colour of what is selected, sRGB to linear colours, and freeing what a group drew.
export const HIGHLIGHT = 0xff00aa;  // the selected frame and the selected element

export const srgbToLinear = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);

// the geometries and materials of an object and everything under it
export function dispose(object) {
  object.traverse((o) => {
    if (o.geometry) o.geometry.dispose();
    if (o.material) o.material.dispose();
  });
}
