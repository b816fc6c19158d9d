//! OBJ + MTL: the input is the OBJ text, then (after a line `%%mtl`) its material library.
//! The OBJ gets `mtllib fuzz.mtl` prepended so every input exercises both parsers.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let (obj, mtl) = spectrace_fuzz::split_obj_mtl(data);
    spectrace_fuzz::put("fuzz.mtl", mtl);
    let mut text = b"mtllib fuzz.mtl\n".to_vec();
    text.extend_from_slice(obj);
    spectrace_fuzz::run_file(&spectrace_fuzz::put("fuzz.obj", &text));
});
