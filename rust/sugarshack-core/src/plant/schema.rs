//! The plant document's JSON Schema, generated from its types: their serde
//! attributes give its shape, their doc comments its descriptions (what an
//! editor shows on hover and beside a completion). Draft 7, which Monaco,
//! VS Code and ajv all read.

use schemars::generate::SchemaSettings;
use schemars::transform::{RecursiveTransform, RestrictFormats};
use schemars::Schema;
use serde_json::Value;

use super::PlantModel;

/// The JSON Schema of a plant document: what serde reads into a [`PlantModel`].
pub fn schema() -> Value {
    let mut settings = SchemaSettings::draft07();
    settings
        .transforms
        .push(Box::new(RecursiveTransform(integer_range)));
    settings
        .transforms
        .push(Box::new(RestrictFormats::default()));
    settings
        .transforms
        .push(Box::new(RecursiveTransform(for_editors)));
    let generated = settings
        .into_generator()
        .into_root_schema_for::<PlantModel>()
        .to_value();
    // What it is first, then its properties, then the definitions they use.
    let Value::Object(mut rest) = generated else {
        unreachable!("a struct's schema is an object")
    };
    let mut ordered = serde_json::Map::new();
    for key in ["$schema", "title", "description"] {
        if let Some(value) = rest.remove(key) {
            ordered.insert(key.into(), value);
        }
    }
    ordered.append(&mut rest);
    Value::Object(ordered)
}

/// The integers serde reads into each integer type, as bounds, since a
/// schema reader knows nothing of `int32` or `uint32`.
fn integer_range(schema: &mut Schema) {
    let bounds = match schema.get("format").and_then(Value::as_str) {
        Some("int32") => (i64::from(i32::MIN), i64::from(i32::MAX)),
        Some("uint32") => (0, i64::from(u32::MAX)),
        _ => return,
    };
    schema.insert("minimum".into(), bounds.0.into());
    schema.insert("maximum".into(), bounds.1.into());
}

/// Descriptions as one paragraph per blank-line-separated block of the doc
/// comment (rustdoc's line breaks are only wrapping), also as
/// `markdownDescription` so that editors render their `code`; no `"default":
/// null`, which an editor would insert on completing the key.
fn for_editors(schema: &mut Schema) {
    if let Some(text) = schema.get("description").and_then(Value::as_str) {
        let text = unwrap_lines(text);
        schema.insert("markdownDescription".into(), text.clone().into());
        schema.insert("description".into(), text.into());
    }
    if schema.get("default") == Some(&Value::Null) {
        schema.remove("default");
    }
}

fn unwrap_lines(text: &str) -> String {
    text.split("\n\n")
        .map(|paragraph| paragraph.split_whitespace().collect::<Vec<_>>().join(" "))
        .collect::<Vec<_>>()
        .join("\n\n")
}
