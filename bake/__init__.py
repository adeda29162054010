"""texbake: bake 3D procedural textures into 2D maps and textured meshes."""
