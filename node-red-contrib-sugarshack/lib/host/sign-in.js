// @ts-check
'use strict';
// Signs a person in with Node-RED's adminAuth for another package (the OPC
// UA server's users), as the editor signs in: POST /auth/token on this
// process's own admin API (Node-RED's users, password hashes, custom
// authenticate functions and limit on attempts), then GET /sugarshack/access
// for what the state API lets them do, then the token is revoked. A success
// is remembered for a few minutes (a password hash costs tens of ms of the
// event loop; a client opening sessions in a loop must not cost one each).
const crypto = require('crypto');
const http = require('http');
const https = require('https');

const REMEMBER_MS = 5 * 60 * 1000;
const MAX_REMEMBERED = 100;
const TIMEOUT_MS = 10000;

/** What a signed-in person may do: `by` (the name), `read`, `write`. @typedef {{ by: string, read: boolean, write: boolean }} Access */

class SignIn {
  constructor(RED) {
    this.RED = RED;
    this.secret = crypto.randomBytes(32);
    /** @type {Map<string, { access: Access, untilMs: number }>} */
    this.remembered = new Map();
  }

  /** Access of `username` with `password`, or null (no adminAuth, wrong name or password, no admin API). */
  async check(username, password) {
    if (typeof username !== 'string' || typeof password !== 'string' || username === '' || username.length > 200 || password.length > 1000) return null;
    const key = `${username}\u0000${crypto.createHmac('sha256', this.secret).update(password).digest('hex')}`;
    const known = this.remembered.get(key);
    if (known && known.untilMs > Date.now()) return known.access;
    this.remembered.delete(key);
    const access = await this.askNodeRed(username, password);
    if (access) {
      const oldest = this.remembered.keys().next().value;
      if (this.remembered.size >= MAX_REMEMBERED && oldest !== undefined) this.remembered.delete(oldest);
      this.remembered.set(key, { access, untilMs: Date.now() + REMEMBER_MS });
    }
    return access;
  }

  async askNodeRed(username, password) {
    const admin = adminUrl(this.RED);
    if (!admin) return null;
    const token = await call(admin, 'POST', 'auth/token', { client_id: 'node-red-admin', grant_type: 'password', scope: '', username, password });
    if (token.status !== 200 || !token.body || typeof token.body.access_token !== 'string') return null;
    const bearer = token.body.access_token;
    try {
      const access = await call(admin, 'GET', 'sugarshack/access', undefined, bearer);
      if (access.status !== 200 || !access.body || access.body.read !== true) return null;
      return { by: username, read: true, write: access.body.write === true };
    } finally {
      await call(admin, 'POST', 'auth/revoke', { token: bearer }, bearer).catch(() => {});
    }
  }
}

/** This process's admin API, on loopback, or null when there is none to sign in with. */
function adminUrl(RED) {
  const { settings, server } = RED;
  if (!settings.adminAuth || settings.httpAdminRoot === false || !server || typeof server.address !== 'function') return null;
  const address = server.address();
  if (!address || typeof address === 'string') return null;
  const host = { '0.0.0.0': '127.0.0.1', '::': '::1' }[address.address] || address.address;
  const root = `/${String(settings.httpAdminRoot || '').replace(/^\/+|\/+$/g, '')}/`.replace('//', '/');
  return { secure: server instanceof https.Server, host, port: address.port, root };
}

/** One request to the admin API: { status, body (parsed JSON, or null) }. */
function call(admin, method, path, body, bearer) {
  const text = body === undefined ? null : JSON.stringify(body);
  const headers = { Accept: 'application/json' };
  if (text !== null) Object.assign(headers, { 'Content-Type': 'application/json', 'Content-Length': Buffer.byteLength(text) });
  if (bearer) headers.Authorization = `Bearer ${bearer}`;
  return new Promise((resolve, reject) => {
    // Our own server, reached on loopback: its certificate may well be self-signed.
    const req = (admin.secure ? https : http).request({
      host: admin.host, port: admin.port, path: admin.root + path, method, headers, timeout: TIMEOUT_MS, rejectUnauthorized: false,
    }, (res) => {
      let answer = '';
      res.setEncoding('utf8');
      res.on('data', (d) => { answer += d; });
      res.on('end', () => {
        let parsed = null;
        try {
          parsed = answer ? JSON.parse(answer) : null;
        } catch {
          parsed = null;
        }
        resolve({ status: res.statusCode, body: parsed });
      });
    });
    req.on('error', reject);
    req.on('timeout', () => req.destroy(new Error(`${method} ${path}: no answer`)));
    if (text !== null) req.write(text);
    req.end();
  });
}

module.exports = { SignIn };
