'use strict';
// The server's people are Node-RED's: a session signs in with a name and
// password of adminAuth, checked by Node-RED itself through the palette's API
// (api.signIn), and then reads if the state API lets that person read
// (sugarshack.read) and calls methods (EStop, Clear, Acknowledge, the shelving
// ones) if it lets them write (sugarshack.write). An anonymous session, only
// when the node allows it, reads and calls nothing.
const { WellKnownRoles, makeRoles, UserNameIdentityToken } = require('node-opcua');

class Users {
  /** api: the palette's API; log(text) for sign-in failures of the API itself. */
  constructor(api, log) {
    this.api = api;
    this.log = log;
    /** @type {Map<string, { by: string, read: boolean, write: boolean }>} access of each name signed in */
    this.access = new Map();
  }

  /** node-opcua's user manager. */
  manager() {
    return {
      isValidUserAsync: (username, password, callback) => {
        this.api.signIn(username, password).then((access) => {
          if (access && access.read) this.access.set(username, access);
          callback(null, Boolean(access && access.read));
        }, (err) => {
          this.log(err);
          callback(null, false);
        });
      },
      getUserRoles: (username) => {
        const access = this.access.get(username);
        if (!access) return makeRoles([WellKnownRoles.Anonymous]);
        return makeRoles(access.write ? [WellKnownRoles.AuthenticatedUser, WellKnownRoles.Operator] : [WellKnownRoles.AuthenticatedUser]);
      },
    };
  }

  /**
   * The person behind a method call ({ by, write }), from its session's user
   * token: nobody may write without a name signed in.
   */
  caller(context) {
    const token = context && context.session ? context.session.userIdentityToken : null;
    if (!(token instanceof UserNameIdentityToken) || typeof token.userName !== 'string') return { by: null, write: false };
    const access = this.access.get(token.userName);
    return { by: token.userName, write: Boolean(access && access.write) };
  }
}

module.exports = { Users };
