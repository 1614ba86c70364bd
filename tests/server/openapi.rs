//! The request and answer schemas of `/openapi.json`, field by field, against what the server
//! really accepts and answers (names, required-ness, types, nulls, enum values, array lengths).
//! `api.rs` checks the routes, parameters and statuses; this file the bodies.

use crate::common;

use common::{TOKEN, TestServer, config};
use reqwest::Method;
use serde_json::{Map, Value, json};

/// The schema `s` stands for: itself, or the component its `$ref` names.
fn resolve<'a>(doc: &'a Value, s: &'a Value) -> &'a Value {
    match s["$ref"].as_str() {
        Some(r) => {
            let name = r
                .strip_prefix("#/components/schemas/")
                .unwrap_or_else(|| panic!("unexpected $ref {r}"));
            let c = &doc["components"]["schemas"][name];
            assert!(c.is_object(), "$ref {r} names no schema");
            c
        }
        None => s,
    }
}

/// The JSON types a schema allows (`type` as a string or a list; none: any).
fn types(s: &Value) -> Vec<&str> {
    match &s["type"] {
        Value::String(t) => vec![t.as_str()],
        Value::Array(ts) => ts.iter().filter_map(Value::as_str).collect(),
        _ => Vec::new(),
    }
}

fn type_of(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "boolean",
        Value::Number(n) if n.is_i64() || n.is_u64() => "integer",
        Value::Number(_) => "number",
        Value::String(_) => "string",
        Value::Array(_) => "array",
        Value::Object(_) => "object",
    }
}

/// Whether `v` is valid under schema `s` (the subset of JSON Schema the document uses: `$ref`,
/// `type`, `enum`, `const`, `required`, `properties`, `additionalProperties: false`, `items`,
/// `minItems`, `maxItems`, `minimum`, `maximum`); `Err` says where and why not.
fn validate(doc: &Value, s: &Value, v: &Value, path: &str) -> Result<(), String> {
    let s = resolve(doc, s);
    if let Some(values) = s["enum"].as_array()
        && !values.contains(v)
    {
        return Err(format!("{path}: {v} is not one of {s}"));
    }
    if !s["const"].is_null() && s["const"] != *v {
        return Err(format!("{path}: {v} is not {}", s["const"]));
    }
    let ts = types(s);
    let t = type_of(v);
    let allowed = ts.is_empty() || ts.contains(&t) || (t == "integer" && ts.contains(&"number"));
    if !allowed {
        return Err(format!("{path}: a {t} where the document says {ts:?}"));
    }
    if let Some(x) = v.as_f64()
        && (s["minimum"].as_f64().is_some_and(|m| x < m)
            || s["maximum"].as_f64().is_some_and(|m| x > m))
    {
        return Err(format!("{path}: {x} is out of the documented range"));
    }
    if let Value::Array(items) = v {
        if s["minItems"]
            .as_u64()
            .is_some_and(|n| (items.len() as u64) < n)
            || s["maxItems"]
                .as_u64()
                .is_some_and(|n| items.len() as u64 > n)
        {
            return Err(format!("{path}: {} items", items.len()));
        }
        if !s["items"].is_null() {
            for (i, item) in items.iter().enumerate() {
                validate(doc, &s["items"], item, &format!("{path}[{i}]"))?;
            }
        }
    }
    if let Value::Object(map) = v {
        for r in s["required"].as_array().into_iter().flatten() {
            let r = r.as_str().unwrap();
            if !map.contains_key(r) {
                return Err(format!("{path}: the required {r} is missing"));
            }
        }
        for (k, x) in map {
            let sub = &s["properties"][k];
            if sub.is_null() {
                if s["additionalProperties"] == false {
                    return Err(format!("{path}: {k} is not documented"));
                }
                continue;
            }
            validate(doc, sub, x, &join(path, k))?;
        }
    }
    Ok(())
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_owned()
    } else {
        format!("{path}.{key}")
    }
}

/// Values the schema `s` forbids, built from `base` (a valid value): the wrong JSON type (a
/// string, a number, a boolean), a value outside an enum, an integer's fraction, one item too many or too few, a number just
/// outside a documented range, and (recursively) an array with one bad item. Nulls are checked
/// on their own.
fn forbidden(doc: &Value, s: &Value, base: &Value) -> Vec<Value> {
    let s = resolve(doc, s);
    let ts = types(s);
    let mut out = Vec::new();
    if let Some(values) = s["enum"].as_array() {
        out.push(json!("no-such-value"));
        if !values.iter().any(Value::is_number) {
            out.push(json!(7));
        }
        return out;
    }
    if !ts.contains(&"string") {
        out.push(json!("x"));
    }
    if !ts.iter().any(|t| ["number", "integer"].contains(t)) {
        out.push(json!(7));
    }
    if !ts.contains(&"boolean") {
        out.push(json!(true));
    }
    if ts.contains(&"integer") && !ts.contains(&"number") {
        out.push(json!(1.5));
    }
    if let Some(m) = s["maximum"].as_f64() {
        out.push(json!(m + 1.0));
    }
    if let Some(m) = s["minimum"].as_f64() {
        out.push(json!(m - 1.0));
    }
    if let Value::Array(items) = base
        && let Some(first) = items.first()
    {
        if let Some(n) = s["maxItems"].as_u64() {
            out.push(Value::Array(vec![first.clone(); n as usize + 1]));
        }
        if let Some(n) = s["minItems"].as_u64().filter(|n| *n > 0) {
            out.push(Value::Array(vec![first.clone(); n as usize - 1]));
        }
        // One bad item (objects are walked field by field instead).
        if !resolve(doc, &s["items"])["properties"].is_object() {
            for bad in forbidden(doc, &s["items"], first) {
                let mut v = items.clone();
                v[0] = bad;
                out.push(Value::Array(v));
            }
        }
    }
    out
}

/// Where a value sits in a request: the keys and indices from the root.
#[derive(Clone)]
enum Step {
    Key(String),
    Index(usize),
}

fn at_mut<'a>(v: &'a mut Value, steps: &[Step]) -> &'a mut Value {
    steps.iter().fold(v, |v, s| match s {
        Step::Key(k) => &mut v[k.as_str()],
        Step::Index(i) => &mut v[*i],
    })
}

fn path_of(steps: &[Step]) -> String {
    let mut p = String::new();
    for s in steps {
        match s {
            Step::Key(k) if p.is_empty() => p.push_str(k),
            Step::Key(k) => {
                p.push('.');
                p.push_str(k);
            }
            Step::Index(i) => p.push_str(&format!("[{i}]")),
        }
    }
    p
}

/// One endpoint's bodies against the document: `method` on `url`, with `token` as the bearer
/// token (none for the public queries, the admin token for admin bodies).
struct Endpoint<'a> {
    s: &'a TestServer,
    doc: &'a Value,
    method: Method,
    url: String,
    token: Option<&'a str>,
}

impl Endpoint<'_> {
    async fn send(&self, body: &Value) -> (u16, Value) {
        self.s
            .admin(self.method.clone(), &self.url, Some(body), self.token)
            .await
    }

    /// The server takes `body`, and the document says it may.
    async fn accepted(&self, schema: &Value, body: &Value, what: &str) -> Value {
        let (st, v) = self.send(body).await;
        assert_eq!(
            st, 200,
            "{} {what}: the server refused {body}: {v}",
            self.url
        );
        validate(self.doc, schema, body, "").unwrap_or_else(|e| {
            panic!(
                "{} {what}: accepted, but the document refuses {body}: {e}",
                self.url
            )
        });
        v
    }

    /// The server refuses `body` naming `path` (or a field inside it), and so does the document.
    async fn refused(&self, schema: &Value, body: &Value, path: &str, what: &str) {
        let (st, v) = self.send(body).await;
        assert!(
            st == 400 || st == 422,
            "{} {what}: the server answered {st} to {body}: {v}",
            self.url
        );
        let field = v["error"]["field"].as_str().unwrap_or("");
        assert!(
            field.starts_with(path),
            "{} {what}: the error names {field:?}, not {path:?}: {v}",
            self.url
        );
        assert!(
            validate(self.doc, schema, body, "").is_err(),
            "{} {what}: refused ({v}), but the document allows {body}",
            self.url
        );
    }

    /// Every field of the object at `steps` in `full` (a request naming every documented field)
    /// against `schema`, the object's schema: the documented names are the ones sent; a
    /// documented required field is one the server cannot do without; a documented type is
    /// what the server takes (null only where the type says `null`); an unknown field is
    /// refused, the error naming it, where the document says `additionalProperties: false`;
    /// then each object inside, recursively.
    async fn walk(&self, root: &Value, full: &Value, schema: &Value, steps: Vec<Step>) {
        let s = resolve(self.doc, schema);
        let here = path_of(&steps);
        let mut base = full.clone();
        let object = at_mut(&mut base, &steps).as_object().unwrap().clone();
        let documented: Vec<&String> = s["properties"].as_object().unwrap().keys().collect();
        let sent: Vec<&String> = object.keys().collect();
        assert_eq!(
            {
                let mut d = documented.clone();
                d.sort();
                d
            },
            {
                let mut s = sent.clone();
                s.sort();
                s
            },
            "{} {here}: the documented fields are not the ones the full request sends",
            self.url
        );
        let required: Vec<&str> = s["required"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|r| r.as_str().unwrap())
            .collect();

        // Unknown fields.
        let mut body = full.clone();
        at_mut(&mut body, &steps)["no_such_field"] = json!(1);
        let (st, v) = self.send(&body).await;
        let closed = s["additionalProperties"] == false;
        assert_eq!(
            closed,
            st == 400,
            "{} {here}: an unknown field was answered {st} ({v}); additionalProperties: {}",
            self.url,
            s["additionalProperties"]
        );
        if closed {
            assert_eq!(
                v["error"]["field"],
                json!(join(&here, "no_such_field")),
                "{} {here}: the error does not name the unknown field: {v}",
                self.url
            );
        }

        for (name, value) in &object {
            let mut keyed = steps.clone();
            keyed.push(Step::Key(name.clone()));
            let path = path_of(&keyed);
            let sub = &s["properties"][name.as_str()];

            // Required-ness: without it.
            let mut body = full.clone();
            at_mut(&mut body, &steps)
                .as_object_mut()
                .unwrap()
                .remove(name);
            if required.contains(&name.as_str()) {
                self.refused(root, &body, &path, "without a required field")
                    .await;
            } else {
                self.accepted(root, &body, &format!("without the optional {path}"))
                    .await;
            }

            // Null.
            let mut body = full.clone();
            *at_mut(&mut body, &keyed) = Value::Null;
            if types(resolve(self.doc, sub)).contains(&"null") {
                self.accepted(root, &body, &format!("{path}: null")).await;
            } else {
                self.refused(root, &body, &path, "null where the type has no null")
                    .await;
            }

            // Every enum value is taken; what the schema forbids is refused.
            if let Some(values) = resolve(self.doc, sub)["enum"].as_array() {
                for e in values {
                    let mut body = full.clone();
                    *at_mut(&mut body, &keyed) = e.clone();
                    self.accepted(root, &body, &format!("{path} = {e}")).await;
                }
            }
            for bad in forbidden(self.doc, sub, value) {
                let mut body = full.clone();
                *at_mut(&mut body, &keyed) = bad.clone();
                self.refused(root, &body, &path, &format!("{path} = {bad}"))
                    .await;
            }

            // Objects inside: this object, and the first item of an array of objects.
            let sub = resolve(self.doc, sub);
            if value.is_object() {
                Box::pin(self.walk(root, full, sub, keyed)).await;
            } else if value.is_array() && resolve(self.doc, &sub["items"])["properties"].is_object()
            {
                let mut item = keyed;
                item.push(Step::Index(0));
                Box::pin(self.walk(root, full, &sub["items"], item)).await;
            }
        }
    }
}

/// The `content` schema `$ref` of an operation's request body or 200 answer.
fn content_ref<'a>(doc: &'a Value, method: &str, path: &str, body: bool) -> &'a Value {
    let op = &doc["paths"][path][method];
    let content = if body {
        &op["requestBody"]["content"]
    } else {
        &op["responses"]["200"]["content"]
    };
    &content["application/json"]["schema"]
}

/// The answers `answers` (minimal, full, and others) against the answer schema: each valid
/// (types, required fields present, nothing undocumented), the full one (`answers[1]`)
/// carrying every documented field, and every optional field absent from at least one.
fn check_answers(doc: &Value, schema: &Value, answers: &[Value], what: &str) {
    for a in answers {
        validate(doc, schema, a, "").unwrap_or_else(|e| panic!("{what}: {a}: {e}"));
    }
    let s = resolve(doc, schema);
    let props: &Map<String, Value> = s["properties"].as_object().unwrap();
    let required: Vec<&Value> = s["required"].as_array().into_iter().flatten().collect();
    for (name, sub) in props {
        assert!(
            answers[1].get(name).is_some(),
            "{what}: the full answer lacks the documented {name}: {}",
            answers[1]
        );
        if !required.contains(&&json!(name)) {
            assert!(
                answers.iter().any(|a| a.get(name).is_none()),
                "{what}: {name} is documented optional but every answer has it"
            );
        }
        // Objects inside arrays: the items of the full answer carry every documented field.
        let items = resolve(doc, &sub["items"]);
        if let (Some(list), Some(item_props)) =
            (answers[1][name].as_array(), items["properties"].as_object())
        {
            for item in list {
                for k in item_props.keys() {
                    assert!(item.get(k).is_some(), "{what}: {name}[]: no {k} in {item}");
                }
            }
        }
    }
}

/// The sample and orientation bodies of `/openapi.json` against the server, for a minimal and
/// a full request. The document used to give no answer schema for either (`"application/json":
/// {}`), leave out `additionalProperties: false` where the server refuses unknown fields, and
/// type as plain numbers and arrays the fields the server also takes as null (`t`, `origin`,
/// `fields`, `accuracy` and its fields, `probes`).
#[tokio::test]
async fn openapi_sample_and_orientation_bodies_match_the_server_field_by_field() {
    let s = TestServer::start(config()).await;
    let (st, doc) = s.get_json("/openapi.json").await;
    assert_eq!(st, 200);

    // Sample: minimal (points only) and every field.
    let path = "/v1/scenes/{id}/sample";
    let req = content_ref(&doc, "post", path, true);
    assert_eq!(req["$ref"], "#/components/schemas/SampleRequest");
    let answer = content_ref(&doc, "post", path, false);
    assert_eq!(answer["$ref"], "#/components/schemas/SampleResponse");
    let e = Endpoint {
        s: &s,
        doc: &doc,
        method: Method::POST,
        url: "/v1/scenes/calm/sample".into(),
        token: None,
    };
    let minimal = json!({"points": [[1.5, -2.0], [3.0, 4.0]]});
    let full = json!({"t": 12.5, "origin": [100.0, -200.0], "points": [[1.5, -2.0], [3.0, 4.0]],
        "fields": ["height", "normal", "displacement", "jacobian", "residual"],
        "accuracy": {"method": "newton", "iterations": 8, "tolerance": 1e-5, "filter": "bicubic",
            "precision": "f64", "time": "grid"}});
    let a_min = e.accepted(req, &minimal, "minimal").await;
    let a_full = e.accepted(req, &full, "full").await;
    let a_normal = e
        .accepted(
            req,
            &json!({"points": [[0, 0]], "fields": ["normal"]}),
            "normal only",
        )
        .await;
    check_answers(&doc, answer, &[a_min, a_full, a_normal], "sample answer");
    e.walk(req, &full, req, Vec::new()).await;

    // Orientation: minimal (a footprint) and every field.
    let path = "/v1/scenes/{id}/orientation";
    let req = content_ref(&doc, "post", path, true);
    assert_eq!(req["$ref"], "#/components/schemas/OrientationRequest");
    let answer = content_ref(&doc, "post", path, false);
    assert_eq!(answer["$ref"], "#/components/schemas/OrientationResponse");
    let e = Endpoint {
        s: &s,
        doc: &doc,
        method: Method::POST,
        url: "/v1/scenes/calm/orientation".into(),
        token: None,
    };
    let minimal = json!({"bodies": [{"position": [5.0, 5.0], "length": 12.0, "beam": 4.0}]});
    let full = json!({"t": 7.25, "bodies": [{"position": [5.0, 5.0], "yaw": 0.3, "length": 12.0,
        "beam": 4.0, "probes": [[-6.0, 0.0], [6.0, -2.0], [6.0, 2.0]]}]});
    let a_min = e.accepted(req, &minimal, "minimal").await;
    let a_full = e.accepted(req, &full, "full").await;
    check_answers(&doc, answer, &[a_min, a_full], "orientation answer");
    e.walk(req, &full, req, Vec::new()).await;

    // The height answer is described too.
    let (st, h) = s.get_json("/v1/scenes/calm/height?x=1&z=2").await;
    assert_eq!(st, 200);
    let height = &doc["paths"]["/v1/scenes/{id}/height"]["get"]["responses"]["200"]["content"]["application/json"]
        ["schema"];
    check_answers(&doc, height, &[h.clone(), h], "height answer");
    s.stop().await;
}

/// The clock body of `/openapi.json` (`PUT …/clock`, admin) against the server, and its answer.
/// The document used to type `rate` and `t` as plain numbers and `paused` as a plain boolean,
/// where the server also takes null for each (an `Option`: the setting stays as it is), leave
/// out the ranges the server checks (|rate| <= 86400, |t| <= `limits.max_time`), and describe
/// no answer for `GET` or `PUT …/clock`.
#[tokio::test]
async fn openapi_clock_body_matches_the_server_field_by_field() {
    let s = TestServer::start(config()).await;
    let (st, doc) = s.get_json("/openapi.json").await;
    assert_eq!(st, 200);
    let path = "/v1/scenes/{id}/clock";
    let req = content_ref(&doc, "put", path, true);
    assert_eq!(req["$ref"], "#/components/schemas/ClockUpdate");
    let answer = content_ref(&doc, "put", path, false);
    assert_eq!(answer["$ref"], "#/components/schemas/ClockReading");
    assert_eq!(content_ref(&doc, "get", path, false), answer);
    // The documented range of `t` is this server's limit.
    let max = swell::Limits::default().max_time;
    let t = &resolve(&doc, req)["properties"]["t"];
    assert_eq!((&t["minimum"], &t["maximum"]), (&json!(-max), &json!(max)));

    let e = Endpoint {
        s: &s,
        doc: &doc,
        method: Method::PUT,
        url: "/v1/scenes/calm/clock".into(),
        token: Some(TOKEN),
    };
    let full = json!({"t": 12.5, "rate": 2.0, "paused": true});
    let a_min = e.accepted(req, &json!({}), "minimal").await;
    let a_full = e.accepted(req, &full, "full").await;
    let (st, a_get) = s.get_json("/v1/scenes/calm/clock").await;
    assert_eq!(st, 200, "{a_get}");
    // The ends of the documented ranges are taken; at the limit, running outwards, the clock
    // holds: the answer reads exactly the limit, paused.
    let max_rate = swell::scene::clock::MAX_RATE;
    let a_edge = e
        .accepted(
            req,
            &json!({"t": max, "rate": -max_rate, "paused": false}),
            "at the ends of the ranges",
        )
        .await;
    let a_held = e
        .accepted(req, &json!({"t": max, "rate": max_rate}), "held")
        .await;
    assert_eq!(
        (&a_held["t"], &a_held["paused"]),
        (&json!(max), &json!(true)),
        "{a_held}"
    );
    check_answers(
        &doc,
        answer,
        &[a_min, a_full, a_get, a_edge, a_held],
        "clock answer",
    );
    e.walk(req, &full, req, Vec::new()).await;
    s.stop().await;
}
