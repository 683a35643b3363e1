use super::*;

#[test]
fn sizes_parse_and_refuse() {
    let parse_size = |text| parse_size("--size", text, 1..=MAX_SIZE);
    assert_eq!(parse_size("800x600").ok(), Some((800, 600)));
    assert_eq!(parse_size("8192X1").ok(), Some((8192, 1)));
    for bad in ["0x10", "10x0", "8193x10", "10", "axb", "-1x5", ""] {
        let e = parse_size(bad).expect_err(bad);
        assert_eq!(e.status(), 2);
        assert!(e.to_string().starts_with("--size"), "{e}");
    }
}

#[test]
fn extensions() {
    assert_eq!(format_of(Path::new("a/b.PNG")).ok(), Some(Format::Png));
    assert_eq!(format_of(Path::new("b.gif")).ok(), Some(Format::Gif));
    assert_eq!(format_of(Path::new("b.mp4")).ok(), Some(Format::Mp4));
    assert!(format_of(Path::new("b.bmp")).is_err());
    assert!(format_of(Path::new("b")).is_err());
}
