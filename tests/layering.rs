//! Data flows one way (docs/architecture.md): the renderer never uses the tools around it.
//! No file outside `src/tools/` names `crate::tools` (or `ember::tools`), and only the
//! binary's `main.rs` calls into them.

use std::path::Path;

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn the_renderer_never_imports_the_tools() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let tools = src.join("tools");
    let renderer: Vec<_> = files.iter().filter(|f| !f.starts_with(&tools) && !f.ends_with("main.rs")).collect();
    assert!(renderer.len() > 40, "found only {} renderer files", renderer.len());
    for f in renderer {
        let text = std::fs::read_to_string(f).unwrap();
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            assert!(
                !code.contains("crate::tools") && !code.contains("ember::tools") && !code.contains("super::tools"),
                "{}:{}: the renderer names the tools: {line}",
                f.display(),
                i + 1
            );
        }
    }
}
