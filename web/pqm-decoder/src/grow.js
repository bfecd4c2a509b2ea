/**
 * Growable typed arrays: capacity doubles up to what is needed, so memory
 * follows what the file has actually delivered rather than what its header
 * claims (a hostile header can claim 2^26 vertices and deliver 3).
 */

/**
 * Returns `arr` if it holds at least `need` elements, else a copy of its
 * first `used` elements in a larger array of the same type.
 * @template {Uint8Array|Uint32Array|Float32Array|Float64Array|Int32Array} T
 * @param {T} arr
 * @param {number} need elements required
 * @param {number} [used=arr.length] elements to keep
 * @returns {T}
 */
export function ensure(arr, need, used = arr.length) {
  if (need <= arr.length) return arr;
  const cap = Math.max(need, Math.min(2 * arr.length + 16, need * 2));
  const out = new arr.constructor(cap);
  out.set(used === arr.length ? arr : arr.subarray(0, used));
  return out;
}
