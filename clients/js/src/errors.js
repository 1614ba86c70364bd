// Typed errors. Callers branch on the class and on `code`:
// - `ArgumentError`: a bad argument, thrown before any request is sent (`field` names it);
// - `SwellError`: the server answered with an error (`status`, and the server's `code`,
//   `message` and `field`, as listed in the README's error table);
// - `TransportError`: no answer (connection refused, socket closed, timeout).

/** A bad argument, caught before any request was made. */
export class ArgumentError extends TypeError {
  constructor(field, message) {
    super(message);
    this.name = 'ArgumentError';
    this.field = field;
  }
}

/** The server refused a request: its HTTP status and `{code, message, field?}`. */
export class SwellError extends Error {
  constructor(status, code, message, field) {
    super(`${code}: ${message}`);
    this.name = 'SwellError';
    this.status = status;
    this.code = code;
    this.serverMessage = message;
    this.field = field;
  }
}

/** The request could not be completed (network failure, closed socket, timeout). */
export class TransportError extends Error {
  constructor(message, cause) {
    super(message, cause === undefined ? undefined : { cause });
    this.name = 'TransportError';
  }
}
