'use strict';
// One line per benchmark target, the same shape in every benchmark, so
// `npm run bench | grep -E '^ *(PASS|MISS)'` lists them all.

/** `  PASS  what: figure (target ...)` */
function verdict(what, figure, pass, target) {
  return `  ${pass ? 'PASS' : 'MISS'}  ${what}: ${figure} (target ${target})`;
}

function median(values) {
  const s = [...values].sort((a, b) => a - b);
  return s.length ? s[Math.floor((s.length - 1) / 2)] : NaN;
}

/** The value at quantile q (0..1) of `values` (nearest rank). */
function quantile(values, q) {
  const s = Float64Array.from(values).sort();
  return s.length ? s[Math.max(0, Math.ceil(q * s.length) - 1)] : NaN;
}

module.exports = { verdict, median, quantile };
