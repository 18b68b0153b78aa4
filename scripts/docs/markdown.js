'use strict';
// What the docs checks read from the repository's markdown: which files are
// docs, their headings' anchors (GitHub's slugs, which the docs site uses
// too), their links, and their fenced blocks with the tags that say how each
// is tested (see CONTRIBUTING.md, "Docs as tests").
const fs = require('fs');
const path = require('path');

const ROOT = path.resolve(__dirname, '..', '..');
/** Where the repository lives on GitHub, as the palette's package.json says. */
const REPO_URL = 'https://github.com/sugarshack/sugarshack';
const BLOB_URL = `${REPO_URL}/blob/main/`;
const SKIP_DIRS = new Set(['node_modules', 'target', '.git', '.run', 'report', 'wasm', 'screenshots-out']);

/** The pages of the docs site: the README, CONTRIBUTING.md, the palette's README and docs/, as repository paths. */
function sitePages() {
  return ['README.md', 'CONTRIBUTING.md', 'node-red-contrib-sugarshack/README.md', ...walk('docs', (f) => f.endsWith('.md'))];
}

/** Every markdown file of the repository (the site's pages and the READMEs beside code). */
function markdownFiles() {
  return walk('.', (f) => f.endsWith('.md'));
}

/** Repository paths under `dir` whose name passes `keep`, sorted. */
function walk(dir, keep) {
  const out = [];
  const visit = (rel) => {
    for (const entry of fs.readdirSync(path.join(ROOT, rel), { withFileTypes: true })) {
      const child = rel === '.' ? entry.name : `${rel}/${entry.name}`;
      if (entry.isDirectory()) {
        if (!SKIP_DIRS.has(entry.name)) visit(child);
      } else if (keep(child)) {
        out.push(child);
      }
    }
  };
  visit(dir);
  return out.sort();
}

const read = (rel) => fs.readFileSync(path.join(ROOT, rel), 'utf8');

/** GitHub's anchor for a heading's text: lower case, punctuation dropped, spaces to hyphens. */
function slug(text) {
  return text.toLowerCase().replace(/[^\p{L}\p{M}\p{N}\p{Pc}\- ]/gu, '').replace(/ /g, '-');
}

/** A slugger that numbers repeats as GitHub does (`x`, `x-1`, `x-2`). */
function slugger() {
  const seen = new Map();
  return (text) => {
    const base = slug(text);
    const n = seen.get(base) || 0;
    seen.set(base, n + 1);
    return n === 0 ? base : `${base}-${n}`;
  };
}

/** A heading's text as GitHub renders it: links to their text, code spans to their content, emphasis dropped. */
function headingText(source) {
  // Odd pieces are code spans, kept as they are; markup goes from the others.
  return source
    .split('`')
    .map((piece, i) => (i % 2 ? piece : piece
      .replace(/!?\[([^\]]*)\]\([^)]*\)/g, '$1')
      .replace(/(\*\*|__)(.+?)\1/g, '$2')
      .replace(/<[^>]+>/g, '')))
    .join('')
    .trim();
}

/**
 * A markdown text split into lines, each marked as inside a fenced block or
 * not, and its fenced blocks: `{ line, info, lang, tags, body }`.
 */
function parse(text) {
  const lines = text.split('\n');
  const fences = [];
  const prose = [];
  let open = null;
  lines.forEach((line, i) => {
    const fence = /^(\s*)(`{3,}|~{3,})(.*)$/.exec(line);
    if (open) {
      if (fence && fence[2].startsWith(open.marker) && fence[3].trim() === '') {
        fences.push({ line: open.line, info: open.info, ...infoOf(open.info), body: open.body.join('\n') });
        open = null;
      } else {
        open.body.push(line.slice(Math.min(open.indent, /^\s*/.exec(line)[0].length)));
      }
      prose.push('');
      return;
    }
    if (fence) {
      open = { line: i + 1, marker: fence[2], indent: fence[1].length, info: fence[3].trim(), body: [] };
      prose.push('');
      return;
    }
    prose.push(line);
  });
  if (open) throw new Error(`a fenced block opened on line ${open.line} is never closed`);
  return { lines, prose, fences };
}

/** A fence's info string: its language, then its test tags (`run`, `stack`, `until=WORD`, `skip: reason`...). */
function infoOf(info) {
  const [lang = '', ...rest] = info.split(/\s+/).filter(Boolean);
  const text = info.slice(lang.length).trim();
  const skip = /^skip:\s*(.*)$/.exec(text);
  if (skip) return { lang, tags: { skip: skip[1].trim() } };
  const tags = {};
  for (const word of rest) {
    const eq = word.indexOf('=');
    if (eq > 0) tags[word.slice(0, eq)] = word.slice(eq + 1);
    else tags[word] = true;
  }
  return { lang, tags };
}

/** The anchors a markdown text's headings make, in order. */
function anchors(text) {
  const next = slugger();
  const out = [];
  for (const line of parse(text).prose) {
    const m = /^ {0,3}#{1,6}\s+(.*?)\s*#*\s*$/.exec(line);
    if (m) out.push(next(headingText(m[1])));
  }
  // Explicit anchors written as HTML (`<a id="...">`) count too.
  for (const m of text.matchAll(/<a\s+(?:id|name)="([^"]+)"/g)) out.push(m[1]);
  return out;
}

/** The links and images of a markdown text outside code: `{ line, target }`. */
function links(text) {
  const out = [];
  parse(text).prose.forEach((line, i) => {
    const noCode = line.replace(/`[^`]*`/g, '');
    for (const m of noCode.matchAll(/\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\)/g)) out.push({ line: i + 1, target: m[1] });
    for (const m of noCode.matchAll(/<(?:a|img)\s[^>]*?(?:href|src)="([^"]+)"/g)) out.push({ line: i + 1, target: m[1] });
  });
  return out;
}

module.exports = {
  ROOT, REPO_URL, BLOB_URL, sitePages, markdownFiles, walk, read, slug, slugger, headingText, parse, infoOf, anchors, links,
};
