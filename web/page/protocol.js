// The wire format of gshell view (docs/viewer.md): JSON text messages, and binary frames with a
// 16-byte header {uint32 kind, uint32 seq, float32 a, float32 b} then float32 / uint32 arrays
// (little endian, as every browser's typed arrays on x86 and ARM).
export const FrameKind = { Faces: 1, Positions: 2, Values: 3, Frame: 4 };
const HEADER = 16;

/** Decodes a binary frame: {kind, seq, a, b, data (a typed array view into the buffer)}. */
export function decodeFrame(buffer) {
  if (buffer.byteLength < HEADER || buffer.byteLength % 4) throw new Error('malformed frame');
  const head = new DataView(buffer, 0, HEADER);
  const kind = head.getUint32(0, true);
  const frame = { kind, seq: head.getUint32(4, true), a: head.getFloat32(8, true), b: head.getFloat32(12, true) };
  const count = (buffer.byteLength - HEADER) / 4;
  frame.data = kind === FrameKind.Faces ? new Uint32Array(buffer, HEADER, count) : new Float32Array(buffer, HEADER, count);
  return frame;
}

/** A drag of group `handle`: its motion from rest (translate, then the rotation as axis/degrees). */
export function dragMessage(seq, handle, translate, quaternion) {
  const { axis, degrees } = axisAngle(quaternion);
  return JSON.stringify({ type: 'drag', seq, handle, translate: [translate.x, translate.y, translate.z], axis, degrees });
}

/** Axis and angle (degrees) of a unit quaternion {x, y, z, w}; the z axis for no rotation. */
export function axisAngle(q) {
  const w = Math.min(1, Math.max(-1, q.w));
  const s = Math.sqrt(Math.max(0, 1 - w * w));
  if (s < 1e-9) return { axis: [0, 0, 1], degrees: 0 };
  return { axis: [q.x / s, q.y / s, q.z / s], degrees: (2 * Math.acos(w) * 180) / Math.PI };
}
