'use strict';
// Checks every internal link of the repository's markdown and of the nodes'
// help: a relative link or a link to this repository on GitHub must name a
// file that exists and, with a #fragment, a heading of that file (GitHub's
// anchors). External links are not followed (the tests run offline).
//   node scripts/docs/links.js     lists every broken link; exits 1 if there is one
const fs = require('fs');
const path = require('path');
const { ROOT, REPO_URL, markdownFiles, walk, read, anchors, links } = require('./markdown');

const HELP_DIR = 'node-red-contrib-sugarshack/nodes/locales';

/** The anchors of a repository file, read once. */
function anchorIndex() {
  const cache = new Map();
  return (rel) => {
    if (!cache.has(rel)) cache.set(rel, new Set(anchors(read(rel))));
    return cache.get(rel);
  };
}

/** The links of a node's help: every href and src. */
function htmlLinks(text) {
  const out = [];
  text.split('\n').forEach((line, i) => {
    for (const m of line.matchAll(/\s(?:href|src)="([^"]+)"/g)) out.push({ line: i + 1, target: m[1] });
  });
  return out;
}

/**
 * Where a link leads inside the repository: `{ file, fragment }` (a repository
 * path, '' for the page itself), or null for a link that leaves it.
 */
function resolve(from, target) {
  const decoded = decodeURI(target);
  const gh = new RegExp(`^${REPO_URL.replace(/[.]/g, '\\.')}/(?:blob|tree)/main/([^#?]*)(?:#(.*))?$`).exec(decoded);
  if (gh) return { file: gh[1].replace(/\/$/, '') || '.', fragment: gh[2] || '' };
  if (/^[a-z][a-z0-9+.-]*:/i.test(decoded) || decoded.startsWith('//')) return null;
  const [file, fragment = ''] = decoded.split('#');
  if (file === '') return { file: from, fragment };
  if (file.startsWith('/')) return { file: file.slice(1), fragment, absolute: true };
  return { file: path.posix.normalize(path.posix.join(path.posix.dirname(from), file)), fragment };
}

/** The files whose links are checked: every markdown file and every node's help, with their links. */
function repositorySources() {
  return [
    ...markdownFiles().map((file) => ({ file, found: links(read(file)) })),
    ...walk(HELP_DIR, (f) => f.endsWith('.html')).map((file) => ({ file, found: htmlLinks(read(file)) })),
  ];
}

const onDisk = { exists: (rel) => fs.existsSync(path.join(ROOT, rel)), anchorsOf: anchorIndex() };

/** Every broken link of `sources`: `{ file, line, target, why }`. */
function brokenLinks(sources = repositorySources(), { exists, anchorsOf } = onDisk) {
  const broken = [];
  for (const { file, found } of sources) {
    for (const { line, target } of found) {
      const to = resolve(file, target);
      if (!to) continue;
      const bad = (why) => broken.push({ file, line, target, why });
      if (to.absolute) {
        bad('a link from the site root does not work on GitHub: write it relative to this file');
      } else if (to.file.startsWith('..')) {
        bad('leaves the repository');
      } else if (!exists(to.file)) {
        bad(`no file ${to.file}`);
      } else if (to.fragment && to.file.endsWith('.md') && !anchorsOf(to.file).has(to.fragment)) {
        bad(`no heading in ${to.file} has the anchor #${to.fragment}`);
      } else if (to.fragment && !to.file.endsWith('.md') && !/^L\d+(-L\d+)?$/.test(to.fragment)) {
        bad(`#${to.fragment}: only markdown files have anchors to check`);
      }
    }
  }
  return broken;
}

if (require.main === module) {
  const broken = brokenLinks();
  for (const b of broken) console.error(`${b.file}:${b.line}: ${b.target}: ${b.why}`);
  console.log(broken.length ? `links: ${broken.length} broken` : 'links: every internal link and anchor resolves');
  process.exit(broken.length ? 1 : 0);
}

module.exports = { brokenLinks, resolve, htmlLinks };
