'use strict';
// Seeded random numbers, one independent stream per name, so a device's noise
// does not depend on how many other devices the plant has or their order.

function hash32(text) {
  // FNV-1a
  let h = 0x811c9dc5;
  for (let i = 0; i < text.length; i++) {
    h ^= text.charCodeAt(i);
    h = Math.imul(h, 0x01000193);
  }
  return h >>> 0;
}

function mulberry32(seed) {
  let a = seed >>> 0;
  return function next() {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

// Returns a generator with helpers; `stream(seed, 'ctrl-1')`.
function stream(seed, name) {
  const next = mulberry32(hash32(`${seed}:${name}`));
  return {
    next,
    // uniform in [-amplitude, +amplitude]
    symmetric(amplitude) { return amplitude ? (next() * 2 - 1) * amplitude : 0; },
    between(lo, hi) { return lo + next() * (hi - lo); },
    chance(ratio) { return ratio > 0 && next() < ratio; },
  };
}

module.exports = { mulberry32, stream, hash32 };
