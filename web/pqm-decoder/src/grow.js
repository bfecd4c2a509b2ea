/**
 * Growable typed arrays: capacity grows geometrically, so memory follows what
 * the file has actually delivered rather than what its header claims (a
 * hostile header can claim 2^26 vertices and deliver 3): an array holds at
 * most 4 times what was delivered. Growth stops at `max` (the file's final
 * count, already checked against the limits), so the last step does not
 * overshoot.
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
  // ×4 when a final count caps the array (it never outgrows the file's
  // claim, already checked against the limits), else ×2: every growth is an
  // allocation, a copy and garbage for the collector (typed arrays count as
  // external memory, whose growth triggers collections), and ×4 copies a
  // third of the final size instead of all of it (bunny: 7 % of the decode)
  const cap = Math.max(need, Math.min((max === Infinity ? 2 : 4) * arr.length + 64, max));
  const out = new arr.constructor(cap);
  out.set(used === arr.length ? arr : arr.subarray(0, used));
  return out;
}
