//! Builds liblouis (C, LGPL-2.1+, vendored in `c/` at the commit README.md names) into this
//! crate's static library. Only a C compiler is needed.

fn main() {
    let dir = std::path::Path::new("c");
    let sources = [
        "compileTranslationTable.c",
        "lou_translateString.c",
        "lou_backTranslateString.c",
        "commonTranslationFunctions.c",
        "metadata.c",
        "pattern.c",
        "logging.c",
        "utils.c",
        "maketable.c",
    ];
    let mut build = cc::Build::new();
    build.include(dir).warnings(false).opt_level(2);
    for s in sources {
        build.file(dir.join(s));
    }
    build.compile("louis");
    println!("cargo::rerun-if-changed=c");
}
