'use strict';
// Builds the docs site with VitePress from the README, CONTRIBUTING.md, the
// palette's README and docs/, then checks the built pages: VitePress fails the
// build on a link to a page that does not exist, and every link with a
// #fragment must find that id in its page. A link that leaves the site's pages (a source file, a flow)
// goes to the repository on GitHub.
//   node scripts/docs/site.js [--out DIR]    (default .run/docs/site)
const fs = require('fs');
const path = require('path');
const { ROOT, BLOB_URL, sitePages, walk, read, parse, headingText, slug } = require('./markdown');

const STAGE = path.join(ROOT, '.run', 'docs', 'src');
const ASSETS = walk('docs', (f) => !f.endsWith('.md'));
const DEFAULT_OUT = path.join(ROOT, '.run', 'docs', 'site');

/** docs/index.md's sections and their links, in order: the sidebar. */
function sidebar() {
  const groups = [{ text: 'Start', items: [{ text: 'README', link: '/' }, { text: 'Contributing', link: '/CONTRIBUTING' }] }];
  for (const line of parse(read('docs/index.md')).prose) {
    const head = /^## (.*)$/.exec(line);
    if (head) groups.push({ text: headingText(head[1]).replace(/:.*$/, ''), items: [] });
    const item = /^- \[([^\]]+)\]\(([^)#]+\.md)\)/.exec(line);
    if (item && groups.length > 1) groups[groups.length - 1].items.push({ text: item[1], link: `/${path.posix.join('docs', item[2]).replace(/\.md$/, '')}` });
  }
  return groups;
}

/** Every page under docs/ is in the sidebar (reachable from docs/index.md), so none is orphaned. */
function orphans(groups) {
  const linked = new Set(groups.flatMap((g) => g.items.map((i) => `${i.link.slice(1)}.md`)));
  return sitePages().filter((p) => p.startsWith('docs/') && p !== 'docs/index.md' && !linked.has(p));
}

/** The VitePress config, as a module file in the staged source. */
function configModule(groups) {
  const markdownJs = JSON.stringify(path.join(__dirname, 'markdown.js'));
  const pages = JSON.stringify(sitePages());
  const assets = JSON.stringify(ASSETS);
  return `import { createRequire } from 'node:module';
import path from 'node:path';
const require = createRequire(import.meta.url);
const { slug } = require(${markdownJs});
const STAGE = ${JSON.stringify(STAGE)};
const INSIDE = new Set([...${pages}, ...${assets}]);
const BLOB = ${JSON.stringify(BLOB_URL)};

// A relative link to a file that is not a page or an asset of the site goes to GitHub.
function outward(md) {
  md.core.ruler.push('sugarshack-outward-links', (state) => {
    const from = path.posix.relative(STAGE, state.env.realPath || state.env.path);
    for (const block of state.tokens) {
      for (const t of block.children || []) {
        const attr = t.type === 'link_open' ? 'href' : t.type === 'image' ? 'src' : null;
        const url = attr && t.attrGet(attr);
        if (!url || /^([a-z][a-z0-9+.-]*:|#|\\/)/i.test(url)) continue;
        const [file, fragment] = url.split('#');
        const target = path.posix.normalize(path.posix.join(path.posix.dirname(from), file));
        const hash = fragment ? '#' + fragment : '';
        if (!INSIDE.has(target)) t.attrSet(attr, BLOB + target + hash);
        // The README is the site's home page.
        else if (target === 'README.md') t.attrSet(attr, (path.posix.relative(path.posix.dirname(from), 'index.md') || 'index.md') + hash);
      }
    }
  });
  // Code spans are text, never Vue: {{ }} or <tag> in them stays as written.
  const code = md.renderer.rules.code_inline;
  md.renderer.rules.code_inline = (tokens, i, ...rest) => code(tokens, i, ...rest).replace(/^<code/, '<code v-pre');
}

export default {
  title: 'sugarshack',
  description: 'A Node-RED palette for event-driven industrial automation, after the Sugar Shack 4.0 architecture',
  rewrites: { 'README.md': 'index.md' },
  outDir: process.env.SUGARSHACK_DOCS_OUT || ${JSON.stringify(DEFAULT_OUT)},
  cacheDir: ${JSON.stringify(path.join(ROOT, '.run', 'docs', 'cache'))},
  ignoreDeadLinks: false,
  lastUpdated: false,
  markdown: { anchor: { slugify: slug }, config: outward },
  themeConfig: {
    nav: ${JSON.stringify(groups.slice(1).map((g) => ({ text: g.text, link: g.items[0].link })))},
    sidebar: ${JSON.stringify(groups)},
    search: { provider: 'local' },
    outline: { level: [2, 3] },
    socialLinks: [{ icon: 'github', link: ${JSON.stringify(BLOB_URL.replace(/\/blob\/main\/$/, ''))} }],
  },
};
`;
}

/** Copies the site's pages and assets into a clean staging directory with the config beside them. */
function stage(groups) {
  fs.rmSync(STAGE, { recursive: true, force: true });
  for (const rel of [...sitePages(), ...ASSETS]) {
    fs.mkdirSync(path.dirname(path.join(STAGE, rel)), { recursive: true });
    fs.copyFileSync(path.join(ROOT, rel), path.join(STAGE, rel));
  }
  fs.mkdirSync(path.join(STAGE, '.vitepress'), { recursive: true });
  fs.writeFileSync(path.join(STAGE, '.vitepress', 'config.mjs'), configModule(groups));
}

/** Every built page's ids, and every link with a #fragment to a built page: each fragment must be an id there. */
function missingAnchors(out) {
  const html = walkAbs(out).filter((f) => f.endsWith('.html'));
  const ids = new Map(html.map((f) => [f, new Set([...fs.readFileSync(f, 'utf8').matchAll(/\sid="([^"]+)"/g)].map((m) => m[1]))]));
  const missing = [];
  for (const file of html) {
    for (const m of fs.readFileSync(file, 'utf8').matchAll(/<a\s[^>]*?href="([^"]*#[^"]*)"/g)) {
      const href = m[1].replace(/&amp;/g, '&');
      if (/^[a-z][a-z0-9+.-]*:/i.test(href) || href.startsWith('//')) continue;
      const [page, fragment] = href.split('#');
      if (!fragment) continue;
      let target = page === '' ? file : page.startsWith('/') ? path.join(out, page) : path.resolve(path.dirname(file), page);
      if (page.endsWith('/') || (fs.existsSync(target) && fs.statSync(target).isDirectory())) target = path.join(target, 'index.html');
      else if (!target.endsWith('.html')) target += '.html';
      const found = ids.get(target);
      if (!found) missing.push(`${path.relative(out, file)}: ${href}: no page ${path.relative(out, target)}`);
      else if (!found.has(decodeURIComponent(fragment))) missing.push(`${path.relative(out, file)}: ${href}: no id "${fragment}" in ${path.relative(out, target)}`);
    }
  }
  return missing;
}

function walkAbs(dir) {
  return fs.readdirSync(dir, { withFileTypes: true }).flatMap((e) => {
    const p = path.join(dir, e.name);
    return e.isDirectory() ? walkAbs(p) : [p];
  });
}

async function buildSite(out = DEFAULT_OUT) {
  const groups = sidebar();
  const lost = orphans(groups);
  if (lost.length) throw new Error(`docs pages not linked from docs/index.md (so not in the site's sidebar): ${lost.join(', ')}`);
  stage(groups);
  process.env.SUGARSHACK_DOCS_OUT = out;
  const { build } = await import('vitepress');
  await build(STAGE, { outDir: out });
  const missing = missingAnchors(out);
  if (missing.length) throw new Error(`links to missing anchors in the built site:\n  ${missing.join('\n  ')}`);
  return { out, pages: walkAbs(out).filter((f) => f.endsWith('.html')).length };
}

if (require.main === module) {
  const i = process.argv.indexOf('--out');
  buildSite(i > 0 ? path.resolve(process.argv[i + 1]) : undefined).then(({ out, pages }) => {
    console.log(`docs site: ${pages} pages in ${path.relative(process.cwd(), out) || out}, every link and anchor resolves`);
  }, (err) => {
    console.error(`docs site: ${err.message}`);
    process.exit(1);
  });
}

module.exports = { buildSite, sidebar, missingAnchors, slug };
