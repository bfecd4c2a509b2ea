/**
 * Growable typed arrays: capacity doubles as needed, so memory follows what
 * the file has actually delivered rather than what its header claims (a
 * hostile header can claim 2^26 vertices and deliver 3). Growth stops at
 * `max` (the file's final count, already checked against the limits), so the
 * last doubling does not overshoot.
 */

/**
 * Returns `arr` if it holds at least `need` elements, else a copy of its
 * first `used` elements in a larger array of the same type.
 * @template {Uint8Array|Uint32Array|Int32Array|Float32Array|Float64Array} T
 * @param {T} arr
 * @param {number} need elements required
 * @param {number} [used=arr.length] elements to keep
 * @param {number} [max=Infinity] largest useful capacity (≥ need)
 * @returns {T}
 */
export function ensure(arr, need, used = arr.length, max = Infinity) {
  if (need <= arr.length) return arr;
  const cap = Math.max(need, Math.min(2 * arr.length + 64, max));
  const out = new arr.constructor(cap);
  out.set(used === arr.length ? arr : arr.subarray(0, used));
  return out;
}
