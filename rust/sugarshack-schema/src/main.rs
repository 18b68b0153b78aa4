//! Writes the plant document's JSON Schema (see `sugarshack_core::plant::schema`)
//! to the file named by its one argument, or to stdout without one.
//!
//! `cargo run -p sugarshack-schema -- node-red-contrib-sugarshack/schema/plant.schema.json`

use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    let text = schema_text();
    let Some(out) = std::env::args_os().nth(1) else {
        print!("{text}");
        return ExitCode::SUCCESS;
    };
    let out = Path::new(&out);
    let written = out
        .parent()
        .map_or(Ok(()), std::fs::create_dir_all)
        .and_then(|()| std::fs::write(out, text));
    match written {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("plant-schema: cannot write {}: {err}", out.display());
            ExitCode::FAILURE
        }
    }
}

/// The schema as pretty JSON with a final newline.
fn schema_text() -> String {
    let schema = sugarshack_core::plant::schema();
    format!(
        "{}\n",
        serde_json::to_string_pretty(&schema).expect("JSON values always serialize")
    )
}

#[cfg(test)]
mod tests {
    use serde_json::Value;

    /// Every key an editor can propose, with where it is, and whether it has a description.
    fn properties(schema: &Value, at: &str, out: &mut Vec<(String, bool)>) {
        match schema {
            Value::Object(map) => {
                if let Some(Value::Object(props)) = map.get("properties") {
                    for (key, value) in props {
                        out.push((format!("{at}.{key}"), value.get("description").is_some()));
                    }
                }
                for (key, value) in map {
                    properties(value, &format!("{at}/{key}"), out);
                }
            }
            Value::Array(items) => items
                .iter()
                .enumerate()
                .for_each(|(i, v)| properties(v, &format!("{at}[{i}]"), out)),
            _ => {}
        }
    }

    #[test]
    fn every_key_and_definition_has_a_description_from_its_doc_comment() {
        let schema = sugarshack_core::plant::schema();
        let mut keys = Vec::new();
        properties(&schema, "", &mut keys);
        let undocumented: Vec<_> = keys.iter().filter(|(_, documented)| !documented).collect();
        assert!(keys.len() > 60, "{} keys", keys.len());
        assert!(undocumented.is_empty(), "{undocumented:#?}");
        let definitions = schema["definitions"].as_object().unwrap();
        let undocumented: Vec<_> = definitions
            .iter()
            .filter(|(_, d)| d.get("description").is_none())
            .map(|(name, _)| name)
            .collect();
        assert!(undocumented.is_empty(), "{undocumented:?}");
    }

    #[test]
    fn descriptions_are_unwrapped_and_also_markdown_and_no_default_is_null() {
        let schema = sugarshack_core::plant::schema();
        let actuator = &schema["definitions"]["Actuator"]["properties"];
        let idle = actuator["idle"]["description"].as_str().unwrap();
        assert!(
            idle.starts_with("Where every operation leaves it when done"),
            "{idle}"
        );
        assert!(!idle.contains('\n'), "rustdoc's wrapping is gone: {idle}");
        assert_eq!(actuator["idle"]["markdownDescription"], idle);
        assert_eq!(actuator["idle"].get("default"), None);
        assert_eq!(schema["properties"]["clockSkewMs"]["default"], 5000);
    }

    #[test]
    fn integers_carry_the_bounds_serde_reads_and_no_format_an_editor_does_not_know() {
        let schema = sugarshack_core::plant::schema();
        let priority = &schema["definitions"]["Operation"]["properties"]["priority"];
        assert_eq!(priority["type"], "integer");
        assert_eq!(priority["minimum"], i64::from(i32::MIN));
        assert_eq!(priority["maximum"], i64::from(i32::MAX));
        assert_eq!(priority.get("format"), None);
        let io = &schema["definitions"]["Actuator"]["properties"]["io"];
        assert_eq!(
            (&io["minimum"], &io["maximum"]),
            (&0.into(), &u32::MAX.into())
        );
        assert!(!super::schema_text().contains("\"format\""));
    }

    #[test]
    fn it_says_what_it_is_first() {
        let schema = sugarshack_core::plant::schema();
        let keys: Vec<&str> = schema
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .take(3)
            .collect();
        assert_eq!(keys, ["$schema", "title", "description"]);
        assert_eq!(schema["$schema"], "http://json-schema.org/draft-07/schema#");
    }
}
