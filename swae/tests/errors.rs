//! Bad input gives errors naming the file, never a panic.

use swae::{Decoder, SwaeError, SwaeSource};

fn tmp(name: &str) -> std::path::PathBuf {
    let p = std::env::temp_dir().join(format!("swae-err-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&p);
    p
}

#[test]
fn missing_data_directory() {
    let p = tmp("missing");
    let e = swae::train::load_split(&p).unwrap_err();
    assert!(matches!(e, SwaeError::Io { .. }));
    assert!(e.to_string().contains(&p.display().to_string()), "{e}");
}

#[test]
fn empty_data_directory() {
    let p = tmp("empty");
    std::fs::create_dir_all(&p).unwrap();
    let e = swae::data::load_dir(&p).unwrap_err();
    assert!(e.to_string().contains("no .bmp or .png"), "{e}");
    std::fs::remove_dir_all(&p).unwrap();
}

#[test]
fn wrong_image_size() {
    let p = tmp("size");
    std::fs::create_dir_all(&p).unwrap();
    image::GrayImage::new(64, 64).save(p.join("1.png")).unwrap();
    let e = swae::data::load_dir(&p).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("1.png") && msg.contains("64 x 64, expected 128 x 128"),
        "{msg}"
    );
    std::fs::remove_dir_all(&p).unwrap();
}

#[test]
fn not_an_image() {
    let p = tmp("garbage");
    std::fs::create_dir_all(&p).unwrap();
    std::fs::write(p.join("2.bmp"), b"not a bitmap").unwrap();
    let e = swae::data::load_dir(&p).unwrap_err();
    assert!(e.to_string().contains("2.bmp"), "{e}");
    std::fs::remove_dir_all(&p).unwrap();
}

#[test]
fn bad_weights_files() {
    let p = tmp("w.safetensors");
    std::fs::write(&p, b"garbage").unwrap();
    for e in [
        Decoder::load(&p).err().unwrap(),
        SwaeSource::from_file(&p, 16.0).err().unwrap(),
        swae::model::Swae::load(&p).err().unwrap(),
    ] {
        assert!(matches!(e, SwaeError::Weights { .. }), "{e}");
        assert!(e.to_string().contains(&p.display().to_string()), "{e}");
    }
    // A valid safetensors file without the decoder's tensors.
    let t: Vec<u8> = [1f32, 2.0].iter().flat_map(|v| v.to_le_bytes()).collect();
    let view = safetensors::tensor::TensorView::new(safetensors::Dtype::F32, vec![2], &t).unwrap();
    safetensors::serialize_to_file([("x", view)], None, &p).unwrap();
    let e = Decoder::load(&p).err().unwrap();
    assert!(
        e.to_string().contains("missing tensor `dec.fc.weight`"),
        "{e}"
    );
    std::fs::remove_file(&p).unwrap();
    let e = Decoder::load(&p).err().unwrap();
    assert!(matches!(e, SwaeError::Io { .. }), "{e}");
    assert!(SwaeSource::committed()
        .unwrap()
        .decoder()
        .decode(&[0.0; 3])
        .is_err());
}
