'use strict';
// How the server may be reached: its endpoint, security modes, certificate and
// user tokens. `None` carries passwords and plant state in clear text, so it is
// offered only on a loopback host, for trying the server out. Basic256Sha256
// Sign and SignAndEncrypt use the server's own certificate, made on first start
// and kept under <userDir>/sugarshack-opcua/pki/own; a client's certificate is
// trusted once moved from pki/rejected/ to pki/trusted/certs/ (or at first
// sight, when the node says so).
const path = require('path');
const { OPCUACertificateManager, MessageSecurityMode, SecurityPolicy } = require('node-opcua');

const LOOPBACK = /^(127\.\d{1,3}\.\d{1,3}\.\d{1,3}|::1|localhost)$/i;

function isLoopback(host) {
  return LOOPBACK.test(String(host));
}

/** A settings error, in the catalog's words (`t`), for the node's status and log. */
class SettingsError extends Error {}

/**
 * The endpoint of `settings` ({ host, port, none, sign, encrypt, anonymous }):
 * node-opcua's endpoint options; throws a SettingsError naming what is wrong.
 */
function endpointOf(settings, t) {
  const { host, port } = settings;
  if (!Number.isInteger(port) || port < 1 || port > 65535) throw new SettingsError(t('errors.badPort', { port: String(port).slice(0, 20) }));
  if (typeof host !== 'string' || host.trim() === '') throw new SettingsError(t('errors.noHost'));
  const modes = [];
  const policies = new Set();
  if (settings.none) {
    if (!isLoopback(host)) throw new SettingsError(t('errors.noneNotLoopback', { host }));
    modes.push(MessageSecurityMode.None);
    policies.add(SecurityPolicy.None);
  }
  if (settings.sign) modes.push(MessageSecurityMode.Sign);
  if (settings.encrypt) modes.push(MessageSecurityMode.SignAndEncrypt);
  if (settings.sign || settings.encrypt) policies.add(SecurityPolicy.Basic256Sha256);
  if (modes.length === 0) throw new SettingsError(t('errors.noSecurityMode'));
  return { port, host, securityModes: modes, securityPolicies: [...policies], allowAnonymous: settings.anonymous === true };
}

/** Where the server keeps its certificate and the clients' it trusts or rejected. */
function pkiDir(userDir) {
  return path.join(userDir, 'sugarshack-opcua', 'pki');
}

/** The server's certificate store (made, with the server's own certificate, on first start). */
function certificateManager(userDir, trustClients) {
  return new OPCUACertificateManager({ rootFolder: pkiDir(userDir), automaticallyAcceptUnknownCertificate: trustClients === true });
}

module.exports = { endpointOf, certificateManager, pkiDir, isLoopback, SettingsError };
