//! The admin token generated when none is configured. Tokens are checked by
//! [`super::admission`] against [`crate::access`].

/// A new random admin token: 32 random bytes as hex.
///
/// # Errors
/// The operating system's random source failed.
pub fn generate_token() -> Result<String, getrandom::Error> {
    let mut b = [0u8; 32];
    getrandom::fill(&mut b)?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_tokens_are_long_and_fresh() {
        let t = generate_token().unwrap();
        assert_eq!(t.len(), 64);
        assert_ne!(t, generate_token().unwrap());
    }
}
