//! Admission: what a request must get past before a handler works on it, in this order.
//!
//! 1. **Rate** — requests per second per client address ([`crate::Limits::peer_requests_per_s`])
//!    and per token ([`crate::Limits::token_requests_per_s`]): 429 `rate_limited` with
//!    `Retry-After`.
//! 2. **Role** — the route's role ([`required_role`]) against the bearer token: 401/403 before a
//!    byte of the body is read (and before `100 Continue` is sent).
//! 3. **Size** — a `Content-Length` over `max_body_bytes`: 413 at once, again without reading.
//! 4. **Body** — read whole, within [`crate::Limits::body_timeout_ms`] and at no less than
//!    [`crate::Limits::body_min_bytes_per_s`] after a short grace: 408 otherwise. The bytes are
//!    charged to the buffer budget (in total and per client) while held: 503 beyond it.
//! 5. **Work** — only now does the request take one of `max_in_flight` slots (503 beyond), so
//!    clients that trickle bodies cannot fill them; the handler runs under the request timeout.
//! 6. **Answer** — a handler whose work holds much memory (a large sample) first grows the
//!    request's charge by what it will hold ([`Reserve`]): 503 beyond the budget, before the
//!    work. The answer's bytes then take the charge's place until hyper has written them (a
//!    client that stops reading holds them only until the connection's send stall timeout).
//!    An answer of shared bytes ([`SharedAnswer`], a cached spectrum) is charged once where it
//!    is cached, not per request.
//!
//! Health probes (`/healthz`, `/readyz`) are routed outside all of this (see [`super::router`]),
//! so no amount of client traffic makes them wait or fail.

use std::net::IpAddr;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::{Duration, Instant};

use axum::body::{Body, Bytes};
use axum::extract::{FromRequestParts, MatchedPath, Request, State};
use axum::http::request::Parts;
use axum::http::{HeaderValue, Method, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use http_body::{Body as _, Frame, SizeHint};
use http_body_util::BodyExt as _;
use tokio::sync::Semaphore;

use crate::access::{Access, Presented, Role};
use crate::config::Limits;
use crate::error::{ApiError, ErrorCode};
use crate::lanes::{Lane, Offence};
use crate::peers::{Budget, Charge, OverBudget, PeerAddr, PeerPolicy, RateLimiter};
use crate::state::AppState;

/// How long a body may take before the minimum rate applies, s: a small body arrives in one
/// packet well within it, and a client on a slow link gets a moment to start.
pub const BODY_RATE_GRACE: Duration = Duration::from_secs(2);

/// How often a body read checks its deadline and rate while no bytes arrive.
const BODY_CHECK_EVERY: Duration = Duration::from_millis(250);

/// The shared state of [`admit`].
#[derive(Debug)]
pub struct Gate {
    state: AppState,
    in_flight: Semaphore,
    budget: Arc<Budget>,
    policy: PeerPolicy,
    per_peer: RateLimiter<IpAddr>,
    per_token: RateLimiter<u64>,
    metrics_public: bool,
}

impl Gate {
    /// The gate for `state`'s limits and access.
    pub fn new(state: AppState, policy: PeerPolicy, budget: Arc<Budget>) -> Arc<Gate> {
        let l = &state.limits;
        Arc::new(Gate {
            in_flight: Semaphore::new(l.max_in_flight.max(1)),
            per_peer: RateLimiter::new(l.peer_requests_per_s, l.peer_requests_burst),
            per_token: RateLimiter::new(l.token_requests_per_s, l.token_requests_burst),
            metrics_public: l.metrics_public,
            budget,
            policy,
            state,
        })
    }
}

/// The role a route needs: `None` for public ones. Reads are public unless
/// `reads_need_token`; `/metrics` needs an admin token unless `metrics_public`.
pub fn required_role(
    method: &Method,
    route: Option<&str>,
    reads_need_token: bool,
    metrics_public: bool,
) -> Option<Role> {
    let route = route?;
    let read = reads_need_token.then_some(Role::Reader);
    match (method.as_str(), route) {
        (_, "/healthz" | "/readyz" | "/openapi.json" | "/docs") => None,
        (_, r) if r == "/viewer" || r.starts_with("/viewer/") => None,
        (_, "/metrics") => (!metrics_public).then_some(Role::Admin),
        ("PUT" | "DELETE", "/v1/scenes/{id}") | ("PUT", "/v1/scenes/{id}/clock") => {
            Some(Role::Admin)
        }
        ("POST", "/v1/scenes/{id}/bodies" | "/v1/scenes/{id}/bodies/{bid}/input")
        | ("DELETE", "/v1/scenes/{id}/bodies/{bid}")
        | ("POST", "/v1/scenes/{id}/impacts") => Some(Role::Game),
        _ => read,
    }
}

/// The bearer token of a request, if it has one.
pub fn bearer(headers: &axum::http::HeaderMap) -> Option<&str> {
    headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| {
            let (scheme, rest) = v.split_once(' ')?;
            scheme.eq_ignore_ascii_case("bearer").then(|| rest.trim())
        })
}

/// Checks a request's token against the role its route needs.
///
/// # Errors
/// 401 `unauthorized` without a token; 403 `forbidden` for a token that is not ours or whose
/// role is below the one needed.
pub fn authorize(need: Option<Role>, presented: Presented) -> Result<(), ApiError> {
    let Some(need) = need else {
        return Ok(());
    };
    match presented {
        Presented::None => Err(ApiError::new(
            ErrorCode::Unauthorized,
            format!(
                "this endpoint needs {} token: Authorization: Bearer <token>",
                a_role(need)
            ),
        )),
        Presented::Unknown => Err(ApiError::new(
            ErrorCode::Forbidden,
            "the token is not valid",
        )),
        Presented::Valid(r) if r >= need => Ok(()),
        Presented::Valid(r) => Err(ApiError::new(
            ErrorCode::Forbidden,
            format!(
                "this endpoint needs {} token; this one is {} token",
                a_role(need),
                a_role(r)
            ),
        )),
    }
}

/// The role's name with its article, for messages: "an admin", "a game", "a reader".
fn a_role(role: Role) -> &'static str {
    match role {
        Role::Admin => "an admin",
        Role::Game => "a game",
        Role::Reader => "a reader",
    }
}

fn rate_limited(what: &str, retry_after: f64) -> Response {
    metrics::counter!("swell_http_rate_limited_total", "key" => what.to_owned()).increment(1);
    let secs = retry_after.ceil().clamp(1.0, 3600.0);
    let mut r = ApiError::new(
        ErrorCode::RateLimited,
        format!("too many requests from this {what}; retry after {secs} s"),
    )
    .into_response();
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    r.headers_mut()
        .insert(header::RETRY_AFTER, HeaderValue::from(secs as u64));
    r
}

fn over_budget(which: OverBudget) -> Response {
    let mut r = ApiError::from(which).into_response();
    r.headers_mut()
        .insert(header::RETRY_AFTER, HeaderValue::from_static("1"));
    r
}

/// A request's charge on the byte budget, shared with its handler: a handler whose work holds
/// much memory grows it first ([`Reserve::bytes`]), and admission then sets it to the answer's
/// size until the answer is written. Outside admission (no budget) it reserves nothing.
#[derive(Clone, Default)]
pub struct Reserve(Option<Arc<Mutex<Charge>>>);

impl Reserve {
    /// Charges `n` more bytes for this request's work.
    ///
    /// # Errors
    /// 503 `overloaded` naming the budget the request would exceed.
    pub fn bytes(&self, n: usize) -> Result<(), ApiError> {
        match &self.0 {
            Some(c) => Ok(lock(c).reserve(n)?),
            None => Ok(()),
        }
    }
}

fn lock(c: &Mutex<Charge>) -> std::sync::MutexGuard<'_, Charge> {
    c.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl<S: Send + Sync> FromRequestParts<S> for Reserve {
    type Rejection = std::convert::Infallible;

    async fn from_request_parts(parts: &mut Parts, _: &S) -> Result<Reserve, Self::Rejection> {
        Ok(parts
            .extensions
            .get::<Reserve>()
            .cloned()
            .unwrap_or_default())
    }
}

/// Put in an answer's extensions by a handler whose body is shared bytes held, and charged to
/// the budget, elsewhere ([`crate::scene::answers`]): sending them to one more client holds no
/// more memory, so the answer is not charged again per request.
#[derive(Debug, Clone, Copy)]
pub struct SharedAnswer;

/// The admission middleware (see the module docs for the order of checks).
pub async fn admit(State(gate): State<Arc<Gate>>, req: Request, next: Next) -> Response {
    let limits = &gate.state.limits;
    let peer = req.extensions().get::<PeerAddr>().map(|p| p.0.ip());
    // The client (through trusted proxies), and the same for the limits: `None` for an
    // exempt one.
    let resolved = peer.map(|p| gate.policy.client(p, req.headers()));
    let client = resolved.filter(|c| !gate.policy.exempt.contains(*c));
    let now = Instant::now();
    if let Some(c) = client
        && let Err(wait) = gate.per_peer.check(c, now)
    {
        let mut r = rate_limited("address", wait);
        // The TCP peer itself over its rate (not a client behind a proxy): demoted to the slow
        // lane, and this connection, if it is not there yet, closes after the answer so that
        // the next request comes through the lane.
        if let Some(p) = peer
            && p == c
            && gate.state.slow_lane.demote(p, Offence::Rate)
            && req.extensions().get::<Lane>() == Some(&Lane::Fast)
        {
            r.headers_mut()
                .insert(header::CONNECTION, HeaderValue::from_static("close"));
        }
        return r;
    }
    let route = req.extensions().get::<MatchedPath>().map(|m| m.as_str());
    let access = &gate.state.access;
    let need = required_role(
        req.method(),
        route,
        access.reads_need_token(),
        gate.metrics_public,
    );
    let token = bearer(req.headers());
    let presented = access.check(token);
    if let Err(e) = authorize(need, presented) {
        return e.into_response();
    }
    if let (Some(t), Presented::Valid(_)) = (token, presented)
        && let Err(wait) = gate.per_token.check(Access::token_key(t), now)
    {
        return rate_limited("token", wait);
    }

    let (parts, body) = req.into_parts();
    let declared = parts
        .headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    let has_body =
        declared.is_some_and(|n| n > 0) || parts.headers.contains_key(header::TRANSFER_ENCODING);
    if declared.is_some_and(|n| n > limits.max_body_bytes as u64) {
        return too_large(limits).into_response();
    }
    let mut charge = gate.budget.charge(client);
    let body = if has_body {
        match read_body(body, declared, limits, &mut charge).await {
            Ok(bytes) => Body::from(bytes),
            Err(r) => {
                if r.status() == axum::http::StatusCode::REQUEST_TIMEOUT
                    && let Some(p) = peer
                {
                    gate.state.slow_lane.demote(p, Offence::SlowBody);
                }
                return r;
            }
        }
    } else {
        body
    };
    let mut req = Request::from_parts(parts, body);
    let body_bytes = charge.bytes();
    let charge = Arc::new(Mutex::new(charge));
    req.extensions_mut()
        .insert(Reserve(Some(Arc::clone(&charge))));

    let Ok(_permit) = gate.in_flight.try_acquire() else {
        metrics::counter!("swell_http_shed_total").increment(1);
        return ApiError::overloaded("too many requests in flight; retry shortly").into_response();
    };
    let timeout = limits.request_timeout();
    // Batch work takes its turn on the compute pool as this client's (exempt or not).
    let work = crate::compute::for_client(resolved, next.run(req));
    let resp = match tokio::time::timeout(timeout, work).await {
        Ok(r) => r,
        Err(_) => {
            return ApiError::new(
                ErrorCode::Timeout,
                format!("the request took longer than {} ms", timeout.as_millis()),
            )
            .into_response();
        }
    };
    // Every 503 (overloaded, timed out) is worth retrying shortly.
    let mut resp = resp;
    if resp.status() == axum::http::StatusCode::SERVICE_UNAVAILABLE {
        resp.headers_mut()
            .entry(header::RETRY_AFTER)
            .or_insert(HeaderValue::from_static("1"));
    }
    // The request body and the work are done; the answer takes their place until written.
    charge_answer(charge, body_bytes, resp)
}

fn too_large(limits: &Limits) -> ApiError {
    ApiError::new(
        ErrorCode::BodyTooLarge,
        format!(
            "request body is larger than the server's limit of {} bytes (max_body_bytes)",
            limits.max_body_bytes
        ),
    )
}

fn request_timeout(message: String) -> Response {
    metrics::counter!("swell_http_body_timeouts_total").increment(1);
    let mut r = ApiError::new(ErrorCode::RequestTimeout, message).into_response();
    // The rest of the body may still come: the connection cannot carry another request.
    r.headers_mut()
        .insert(header::CONNECTION, HeaderValue::from_static("close"));
    r
}

/// Reads a whole body within the size limit, the deadline and the minimum rate, charging its
/// bytes to `charge` as they arrive.
async fn read_body(
    mut body: Body,
    declared: Option<u64>,
    limits: &Limits,
    charge: &mut Charge,
) -> Result<Bytes, Response> {
    let start = Instant::now();
    let deadline = start + limits.body_timeout();
    let rate = limits.body_min_bytes_per_s as f64;
    if let Some(n) = declared {
        // Charged up front: a client cannot make the server start reading what it cannot hold.
        #[allow(clippy::cast_possible_truncation)]
        charge.grow(n as usize).map_err(over_budget)?;
    }
    let mut charged = declared.unwrap_or(0) as usize;
    let mut buf = bytes::BytesMut::with_capacity(charged.min(limits.max_body_bytes));
    let mut tick = tokio::time::interval_at(
        tokio::time::Instant::now() + BODY_CHECK_EVERY,
        BODY_CHECK_EVERY,
    );
    loop {
        let frame = tokio::select! {
            f = body.frame() => Some(f),
            _ = tick.tick() => None,
        };
        let elapsed = start.elapsed();
        match frame {
            Some(Some(Ok(f))) => {
                if let Ok(data) = f.into_data() {
                    let total = buf.len() + data.len();
                    if total > limits.max_body_bytes {
                        return Err(too_large(limits).into_response());
                    }
                    if total > charged {
                        charge.grow(total - charged).map_err(over_budget)?;
                        charged = total;
                    }
                    buf.extend_from_slice(&data);
                }
            }
            Some(Some(Err(e))) => {
                return Err(ApiError::new(
                    ErrorCode::BadBody,
                    format!("the request body could not be read: {e}"),
                )
                .into_response());
            }
            Some(None) => return Ok(buf.freeze()),
            None => {} // a check while waiting
        }
        if Instant::now() >= deadline {
            return Err(request_timeout(format!(
                "the request body did not arrive within {} ms (body_timeout_ms)",
                limits.body_timeout_ms
            )));
        }
        if elapsed > BODY_RATE_GRACE && rate > 0.0 {
            let due = rate * (elapsed - BODY_RATE_GRACE).as_secs_f64();
            let due = declared.map_or(due, |n| due.min(n as f64));
            if (buf.len() as f64) < due {
                return Err(request_timeout(format!(
                    "the request body arrives slower than {} bytes/s (body_min_bytes_per_s)",
                    limits.body_min_bytes_per_s
                )));
            }
        }
    }
}

/// Answers of at least this many bytes are charged until written; smaller ones (most) are not
/// worth the bookkeeping.
const CHARGED_ANSWER_BYTES: u64 = 64 * 1024;

/// Sets the request's charge to the answer's size and wraps the answer's body so the charge
/// holds until it is written (or the connection drops it). An answer that would exceed the
/// budget is replaced by a 503. An answer encoded as it is sent has no size yet: it keeps what
/// its handler reserved (the request's `body_bytes` are gone by now).
fn charge_answer(charge: Arc<Mutex<Charge>>, body_bytes: usize, resp: Response) -> Response {
    if resp.extensions().get::<SharedAnswer>().is_some() {
        return resp; // the charge drops here: the bytes are the cache's
    }
    let hint = resp.body().size_hint();
    let size = hint.upper();
    {
        let mut c = lock(&charge);
        let keep = match size {
            Some(n) if n < CHARGED_ANSWER_BYTES => 0,
            #[allow(clippy::cast_possible_truncation)]
            Some(n) => n as usize,
            None => c.bytes().saturating_sub(body_bytes),
        };
        if let Err(which) = c.resize(keep) {
            return over_budget(which);
        }
        if c.bytes() == 0 {
            return resp;
        }
    }
    let (parts, body) = resp.into_parts();
    Response::from_parts(
        parts,
        Body::new(Charged {
            body,
            _charge: charge,
        }),
    )
}

/// A body that holds its [`Charge`] until dropped.
struct Charged {
    body: Body,
    _charge: Arc<Mutex<Charge>>,
}

impl http_body::Body for Charged {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, axum::Error>>> {
        Pin::new(&mut self.body).poll_frame(cx)
    }

    fn is_end_stream(&self) -> bool {
        self.body.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.body.size_hint()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn routes_and_roles() {
        let get = Method::GET;
        let r = |m: &Method, p: &str| required_role(m, Some(p), false, true);
        assert_eq!(r(&Method::PUT, "/v1/scenes/{id}"), Some(Role::Admin));
        assert_eq!(r(&Method::DELETE, "/v1/scenes/{id}"), Some(Role::Admin));
        assert_eq!(r(&Method::PUT, "/v1/scenes/{id}/clock"), Some(Role::Admin));
        assert_eq!(r(&Method::POST, "/v1/scenes/{id}/bodies"), Some(Role::Game));
        assert_eq!(
            r(&Method::POST, "/v1/scenes/{id}/bodies/{bid}/input"),
            Some(Role::Game)
        );
        assert_eq!(
            r(&Method::POST, "/v1/scenes/{id}/impacts"),
            Some(Role::Game)
        );
        assert_eq!(r(&get, "/v1/scenes/{id}/impacts"), None);
        assert_eq!(r(&Method::POST, "/v1/scenes/{id}/sample"), None);
        assert_eq!(
            required_role(&Method::POST, Some("/v1/scenes/{id}/sample"), true, true),
            Some(Role::Reader)
        );
        assert_eq!(required_role(&get, Some("/healthz"), true, false), None);
        assert_eq!(
            required_role(&get, Some("/metrics"), false, false),
            Some(Role::Admin)
        );
        assert_eq!(required_role(&get, None, true, false), None);
    }

    /// The 401/403 messages used to say "needs a admin token".
    #[test]
    fn token_messages_take_the_right_article() {
        use axum::http::StatusCode;
        let e = authorize(Some(Role::Admin), Presented::None).unwrap_err();
        assert_eq!(e.status(), StatusCode::UNAUTHORIZED);
        assert!(
            e.message.starts_with("this endpoint needs an admin token:"),
            "{}",
            e.message
        );
        let e = authorize(Some(Role::Admin), Presented::Valid(Role::Game)).unwrap_err();
        assert_eq!(e.status(), StatusCode::FORBIDDEN);
        assert_eq!(
            e.message,
            "this endpoint needs an admin token; this one is a game token"
        );
        let e = authorize(Some(Role::Game), Presented::Valid(Role::Reader)).unwrap_err();
        assert_eq!(
            e.message,
            "this endpoint needs a game token; this one is a reader token"
        );
    }
}
