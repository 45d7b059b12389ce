"""Host-side HMI previews and sample states (render_cli, samples): not deployed to the board."""
